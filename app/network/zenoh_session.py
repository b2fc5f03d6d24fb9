"""Opening a Zenoh session for the rig: peer mode on the local network by default, a config file
for everything else (a router to connect to, fixed endpoints, no multicast scouting).

`open_session(config_file)` reads the file with `zenoh.Config.from_file` (JSON5, Zenoh's own
format: https://zenoh.io/docs/manual/configuration/); a file that is missing, unreadable or not
a valid Zenoh configuration, or a session that cannot open (an endpoint that cannot be bound), is
an AppError: one line, no traceback. `add_zenoh_arguments` gives a command `--publish`,
`--rig-name` and `--zenoh-config`.
"""

from __future__ import annotations

import argparse
import os
import re
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.network.messages import DEFAULT_RIG, rig_name

_logging_started = False


def add_zenoh_arguments(parser: argparse.ArgumentParser, *, publish: bool = True) -> argparse._ArgumentGroup:
    """`--publish` (with `publish`), `--rig-name`, `--zenoh-config`, in a group (returned)."""
    group = parser.add_argument_group("Zenoh (README, 'Publishing over Zenoh')")
    if publish:
        group.add_argument(
            "--publish",
            action="store_true",
            help="publish the tracked markers and each camera's dots (and throws) over Zenoh under wiithrow/RIG-NAME/",
        )
    group.add_argument(
        "--rig-name",
        type=_rig_name_argument,
        default=None,
        metavar="NAME",
        help=f"the rig's name in the key expressions (default: {DEFAULT_RIG})",
    )
    group.add_argument(
        "--zenoh-config",
        metavar="FILE",
        default=None,
        help="Zenoh configuration (JSON5): a router, fixed endpoints (default: peer mode, multicast scouting)",
    )
    return group


def _rig_name_argument(text: str) -> str:
    try:
        return rig_name(text)
    except AppError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def load_config(config_file: str | os.PathLike[str] | None) -> Any:
    """The zenoh.Config of `config_file` (None: Zenoh's defaults, peer mode); AppError when bad."""
    import zenoh

    if config_file is None:
        return zenoh.Config()
    path = os.fspath(config_file)
    if not os.path.isfile(path):
        raise AppError(f"no Zenoh configuration file {path!r}")
    try:
        return zenoh.Config.from_file(path)
    except Exception as exc:  # zenoh.ZError, or a decoding error the binding raises as another type
        raise AppError(f"bad Zenoh configuration {path!r}: {one_line(exc)}") from None


def open_session(config_file: str | os.PathLike[str] | None = None) -> Any:
    """An open zenoh.Session (close it: `session.close()`); AppError for a bad config or endpoint."""
    import zenoh

    global _logging_started
    if not _logging_started:  # Zenoh logs to stderr only what the environment (RUST_LOG) asks, errors otherwise
        zenoh.init_log_from_env_or("error")
        _logging_started = True
    config = load_config(config_file)
    try:
        return zenoh.open(config)
    except Exception as exc:
        where = f" with {os.fspath(config_file)!r}" if config_file is not None else ""
        raise AppError(f"cannot open a Zenoh session{where}: {one_line(exc)}") from None


def one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    text = re.sub(r" at /\S+?\.rs:\d+\.?", "", text)  # where in Zenoh's Rust source: no help to a user
    return text[:300] + ("..." if len(text) > 300 else "")
