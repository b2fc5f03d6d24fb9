"""`--foxglove [PORT]` on the command line: what the command tracks, served live to Foxglove.

`add_foxglove_arguments` gives a command `--foxglove [PORT]` (default port 8765; 0: a free one),
served on this host's loopback only (`wiithrow.app.foxglove.live`: no other host in this
version, the server has no token; an SSH tunnel reaches it); `foxglove_rig` serves a rig or a replay, `foxglove_session`
a session (its rig, arm and throws). Both print the URL to open in Foxglove on stderr and, closed,
stop the server.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from wiithrow.app.cli.arguments import port

if TYPE_CHECKING:
    from wiithrow.app.rig.pipeline import TrackingPipeline
    from wiithrow.app.session import Session

DEFAULT_PORT = 8765


def add_foxglove_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--foxglove",
        nargs="?",
        type=port,
        const=DEFAULT_PORT,
        default=None,
        metavar="PORT",
        help=f"serve the channels of a recording live to Foxglove on ws://127.0.0.1:PORT (default {DEFAULT_PORT}; "
        "this host only)",
    )


def _announce(command: str, live: Any) -> None:
    print(
        f"wiithrow {command}: Foxglove live on {live.url()} (Foxglove: Open connection, Foxglove WebSocket)",
        file=sys.stderr,
        flush=True,
    )


def foxglove_rig(args: argparse.Namespace, command: str, rig: TrackingPipeline, frame_id: str) -> Any:
    """With --foxglove: serve `rig` until the result is closed; else None."""
    if getattr(args, "foxglove", None) is None:
        return None
    from wiithrow.app.foxglove.live import FoxgloveLive

    live = FoxgloveLive(rig, port=args.foxglove, frame_id=frame_id)
    _announce(command, live)
    return live


def foxglove_session(args: argparse.Namespace, command: str, session: Session) -> Any:
    """With --foxglove: serve `session` until the result is closed; else None."""
    if getattr(args, "foxglove", None) is None:
        return None
    from wiithrow.app.foxglove.live import FoxgloveSessionLive

    live = FoxgloveSessionLive(session, port=args.foxglove)
    _announce(command, live)
    return live
