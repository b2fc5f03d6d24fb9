"""`--foxglove [PORT]` on the command line: what the command tracks, served live to Foxglove.

`add_foxglove_arguments` gives a command `--foxglove [PORT]` (default port 8765; 0: a free one),
served on this host's loopback, `--foxglove-host HOST` and `--foxglove-insecure-network`: another
host only with the latter (`wiithrow.app.foxglove.live.check_host`: the server cannot check a
token; an SSH tunnel is the safe way). `check_foxglove_arguments` refuses them before the command's
work starts; `foxglove_rig` serves a rig (`FoxgloveProcessLive`: its server in a writer process),
`foxglove_session` a session (its rig, arm and throws: `FoxgloveSessionProcessLive`, a writer
process too). Both print the URL to open in Foxglove on stderr (and, beyond loopback, what that exposes)
and, closed, stop the server.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from wiithrow.app.cli.arguments import port, refuse_flags
from wiithrow.app.errors import AppError

if TYPE_CHECKING:
    from wiithrow.app.rig.pipeline import TrackingPipeline
    from wiithrow.app.session import Session

DEFAULT_PORT = 8765
LOOPBACK = "127.0.0.1"
FOXGLOVE_FLAGS = ("foxglove_host", "foxglove_insecure_network")


def add_foxglove_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("Foxglove (docs/integrations/foxglove.md)")
    group.add_argument(
        "--foxglove",
        nargs="?",
        type=port,
        const=DEFAULT_PORT,
        default=None,
        metavar="PORT",
        help=f"serve the channels of a recording live to Foxglove on ws://127.0.0.1:PORT (default {DEFAULT_PORT}; "
        "this host only unless --foxglove-host)",
    )
    group.add_argument(
        "--foxglove-host",
        metavar="HOST",
        default=None,
        help="with --foxglove: the address to listen on (default 127.0.0.1); beyond loopback only with "
        "--foxglove-insecure-network (the server cannot check a token: prefer an SSH tunnel)",
    )
    group.add_argument(
        "--foxglove-insecure-network",
        action="store_true",
        help="with --foxglove-host beyond loopback: accept that whoever reaches the port sees the rig live "
        "(a trusted network only)",
    )


def foxglove_host(args: argparse.Namespace) -> str:
    """The host Foxglove live listens on: `--foxglove-host`, loopback by default."""
    host = getattr(args, "foxglove_host", None)
    return LOOPBACK if host is None else str(host)


def check_foxglove_arguments(args: argparse.Namespace) -> None:
    """Refuse the Foxglove flags without --foxglove, and a host beyond loopback without
    --foxglove-insecure-network (or that flag with a loopback host)."""
    from wiithrow.app.channels.foxglove_sink import check_host, is_loopback_host

    if getattr(args, "foxglove", None) is None:
        refuse_flags(args, FOXGLOVE_FLAGS, "without --foxglove")
        return
    insecure = bool(getattr(args, "foxglove_insecure_network", False))
    if insecure and is_loopback_host(foxglove_host(args)):
        raise AppError(
            "--foxglove-insecure-network does not apply without --foxglove-host beyond loopback (without one, "
            "Foxglove live stays on this host's loopback)"
        )
    check_host(foxglove_host(args), insecure_network=insecure)


def announce_foxglove(command: str, live: Any, host: str) -> None:
    """Say on stderr where Foxglove connects, and warn when it listens beyond loopback."""
    print(
        f"wiithrow {command}: Foxglove live on {live.url()} (Foxglove: Open connection, Foxglove WebSocket)",
        file=sys.stderr,
        flush=True,
    )
    from wiithrow.app.channels.foxglove_sink import is_loopback_host

    if not is_loopback_host(host):
        print(
            f"NOTE: Foxglove live listens on {host}:{live.port} without authentication (--foxglove-insecure-network):"
            " whoever reaches this port sees the rig live (and cannot act on it: the server takes no client messages)",
            file=sys.stderr,
            flush=True,
        )


def foxglove_rig(args: argparse.Namespace, command: str, rig: TrackingPipeline, frame_id: str) -> Any:
    """With --foxglove: serve `rig` until the result is closed; else None."""
    if getattr(args, "foxglove", None) is None:
        return None
    from wiithrow.app.channels.foxglove_sink import FoxgloveProcessLive

    host = foxglove_host(args)
    insecure = bool(getattr(args, "foxglove_insecure_network", False))
    # the server and the encoding in a writer process: the tracking thread only hands the events over
    live = FoxgloveProcessLive(
        rig, port=args.foxglove, frame_id=frame_id, host=host, insecure_network=insecure, command=command
    )
    announce_foxglove(command, live, host)
    return live


def foxglove_session(args: argparse.Namespace, command: str, session: Session) -> Any:
    """With --foxglove: serve `session` until the result is closed; else None."""
    if getattr(args, "foxglove", None) is None:
        return None
    from wiithrow.app.foxglove.session_process_live import FoxgloveSessionProcessLive

    host = foxglove_host(args)
    insecure = bool(getattr(args, "foxglove_insecure_network", False))
    # the server and the encoding in a writer process: the session's threads only hand its messages over
    live = FoxgloveSessionProcessLive(
        session, port=args.foxglove, host=host, insecure_network=insecure, command=command
    )
    announce_foxglove(command, live, host)
    return live
