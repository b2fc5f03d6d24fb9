"""Opening a Zenoh session for the rig: closed to this host by default, a config file (checked) for
reaching another host.

Without a config file (`open_session(None)`) a session is a Zenoh peer on this host's loopback
only, with no scouting on any network: it listens on `tcp/127.0.0.1:PORT`, the *local meeting
port* (`LOCAL_PORT`, 7450, or `$WIITHROW_ZENOH_PORT`; not Zenoh's 7447, so that a zenohd or ROS 2
router on this host is not joined by accident) when that port is free, and otherwise listens on a
random loopback port and connects to the session that holds it. Peers that meet there learn each
other's loopback endpoints by gossip over those links and connect directly, so any number of
wiithrow processes on one machine find each other with no configuration (a publisher and
`wiithrow listen` in two processes, in either order; when the holder ends, the others keep
their links and the next session to start takes the port), and nothing leaves the machine.

`open_session(config_file)` reads the file with `zenoh.Config.from_file` (JSON5, Zenoh's own
format: https://zenoh.io/docs/manual/configuration/, examples/zenoh/); a file that is missing,
unreadable or not a valid Zenoh configuration, or a session that cannot open (an endpoint that
cannot be bound), is an AppError: one line, no traceback. So is a configuration that listens on,
connects to or scouts a network beyond loopback without Zenoh's authentication
(`zenoh_exposure`), unless `insecure_network` (the CLI's `--insecure-network`), which then warns on
stderr. `add_zenoh_arguments` gives a command `--publish`, `--rig-name`, `--zenoh-config` and
`--insecure-network`.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from typing import Any

from wiithrow.app.errors import AppError
from wiithrow.app.network.messages import DEFAULT_RIG, rig_name
from wiithrow.app.network.zenoh_exposure import exposure
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import MAX_JSON_DEPTH, json_depth, read_text

#: The loopback TCP port the sessions of one host meet on without a config file.
LOCAL_PORT = 7450
#: The environment variable that moves it (the test suite's own port, two users on one host).
LOCAL_PORT_ENV = "WIITHROW_ZENOH_PORT"

_logging_started = False


def add_zenoh_arguments(parser: argparse.ArgumentParser, *, publish: bool = True) -> argparse._ArgumentGroup:
    """`--publish` (with `publish`), `--rig-name`, `--zenoh-config`, `--insecure-network`, in a group (returned)."""
    group = parser.add_argument_group("Zenoh (docs/integrations/zenoh.md)")
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
    add_zenoh_config_arguments(group)
    return group


def add_zenoh_config_arguments(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """`--zenoh-config FILE` and `--insecure-network`."""
    parser.add_argument(
        "--zenoh-config",
        metavar="FILE",
        default=None,
        help="Zenoh configuration (JSON5) to reach other hosts, e.g. examples/zenoh/ (mutual TLS); default: "
        f"this host's loopback only (tcp/127.0.0.1:{LOCAL_PORT}, ${LOCAL_PORT_ENV}), no scouting",
    )
    parser.add_argument(
        "--insecure-network",
        action="store_true",
        help="accept a --zenoh-config that listens, connects or scouts beyond loopback without authentication "
        "(anyone on that network can then read the markers and publish into them)",
    )


def _rig_name_argument(text: str) -> str:
    try:
        return rig_name(text)
    except AppError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def local_port() -> int:
    """The local meeting port: $WIITHROW_ZENOH_PORT, or LOCAL_PORT."""
    text = os.environ.get(LOCAL_PORT_ENV, "").strip()
    if not text:
        return LOCAL_PORT
    if not text.isdigit() or not 1 <= int(text) <= 65535:
        raise AppError(f"${LOCAL_PORT_ENV} must be a TCP port (1-65535), not {text!r}")
    return int(text)


def local_config(listen: str, connect: list[str]) -> Any:
    """A peer on loopback only: listening on `listen`, connecting to `connect`, TCP, no multicast,
    gossip (over its own links) on."""
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", json.dumps([listen]))
    config.insert_json5("connect/endpoints", json.dumps(connect))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "true")
    config.insert_json5("transport/link/protocols", '["tcp"]')
    return config


def load_config(config_file: str | os.PathLike[str] | None) -> Any:
    """The zenoh.Config of `config_file` (None: the loopback peer that holds the local meeting
    port); AppError when bad."""
    import zenoh

    if config_file is None:
        return local_config(f"tcp/127.0.0.1:{local_port()}", [])
    path = os.fspath(config_file)
    if not os.path.isfile(path):
        raise AppError(f"no Zenoh configuration file {path!r}")
    # Zenoh's own parser recurses: arrays nested 40,000 deep crashed the process (a segfault), so
    # the nesting is judged on the text first (JSON5's single-quoted strings and comments count
    # their brackets too: an upper bound, and no Zenoh configuration nests a tenth as deep)
    try:
        depth = json_depth(read_text(path))
    except FileFormatError as exc:
        raise AppError(f"bad Zenoh configuration: {exc}") from None
    if depth > MAX_JSON_DEPTH:
        raise AppError(
            f"bad Zenoh configuration {path!r}: nested deeper than {MAX_JSON_DEPTH} levels, which no Zenoh "
            "configuration is; the file is corrupt"
        )
    try:
        return zenoh.Config.from_file(path)
    except Exception as exc:  # zenoh.ZError, or a decoding error the binding raises as another type
        raise AppError(f"bad Zenoh configuration {path!r}: {one_line(exc)}") from None


def check_exposure(config: Any, config_file: str | os.PathLike[str], insecure_network: bool) -> None:
    """AppError when `config` reaches past loopback unauthenticated, unless `insecure_network` (then a warning)."""
    reason = exposure(config)
    if reason is None:
        return
    consequence = "anyone on that network can read the markers and publish markers that move the arm"
    if not insecure_network:
        raise AppError(
            f"the Zenoh configuration {os.fspath(config_file)!r} {reason}: {consequence}; use mutual TLS or "
            "user/password (examples/zenoh/, docs/integrations/zenoh.md, 'Two hosts'), or pass --insecure-network"
        )
    print(f"wiithrow: warning: --insecure-network: the Zenoh session {reason}: {consequence}", file=sys.stderr)


def open_session(config_file: str | os.PathLike[str] | None = None, *, insecure_network: bool = False) -> Any:
    """An open zenoh.Session (close it: `session.close()`); AppError for a bad config or endpoint,
    or a config that reaches past loopback without authentication (unless `insecure_network`)."""
    import zenoh

    global _logging_started
    if not _logging_started:  # Zenoh logs to stderr only what the environment (RUST_LOG) asks, errors otherwise
        zenoh.init_log_from_env_or("error")
        _logging_started = True
    if config_file is None:
        return _open_local()
    config = load_config(config_file)
    check_exposure(config, config_file, insecure_network)
    try:
        return zenoh.open(config)
    except Exception as exc:
        raise AppError(f"cannot open a Zenoh session with {os.fspath(config_file)!r}: {one_line(exc)}") from None


def _open_local() -> Any:
    """The loopback peer: the holder of the local meeting port, or (taken) one that connects to it."""
    import zenoh

    port = local_port()
    try:
        return zenoh.open(load_config(None))
    except Exception:  # the port is taken (another wiithrow session holds it): meet it there
        pass
    try:
        return zenoh.open(local_config("tcp/127.0.0.1:0", [f"tcp/127.0.0.1:{port}"]))
    except Exception as exc:
        raise AppError(f"cannot open a Zenoh session on this host's loopback: {one_line(exc)}") from None


def one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    text = re.sub(r" at /\S+?\.rs:\d+\.?", "", text)  # where in Zenoh's Rust source: no help to a user
    return text[:300] + ("..." if len(text) > 300 else "")
