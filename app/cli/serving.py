"""Serving a session with the dashboard from the command line (`wiithrow demo`, `wiithrow serve`).

Owns the dashboard's access options (`add_access_arguments`, `access_from_args`: the operator
token, the further host names and the most guests at once, checked before anything starts: a bad token file, or an address
beyond loopback without a chosen token, is one line and exit 2), `--train-to` (a file the Training
panel's library also goes to, its saved run resumed beside it: `add_train_to_argument`,
`train_to_from_args`) and `run_dashboard`: start the
dashboard, print its address (the operator's link with the token, once, and nowhere else), log
refused requests on stderr, optionally start a calibration once the first operator's page has
connected (so that the page shows it from its first pose; the terminal says it waits), run until
Ctrl-C or a duration, then stop the arm, let the running operation end and close everything.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wiithrow.app.calibration.robot import DEFAULT_POSES
from wiithrow.app.cli.heap import frozen_heap
from wiithrow.app.session import Session

if TYPE_CHECKING:
    from wiithrow.web.access import Token
    from wiithrow.web.server import Dashboard

#: What the terminal says while the automatic calibration waits for the first operator's page.
WAITING = (
    "wiithrow dashboard: waiting for an operator's page to calibrate ({poses} poses): open the operator's link "
    "above; the page shows the calibration from its first pose"
)


@dataclass(frozen=True)
class Access:
    """Who the dashboard lets in: the operator token (None: a new random one) and the host names
    it answers to beyond loopback and the bound address."""

    token: Token | None = None
    allow_hosts: tuple[str, ...] = ()
    max_guests: int = 16


def add_access_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--token",
        help="the operator token (default: a random one, printed in the link at start); other users "
        "can read a command line: a service gives it with --token-file or $WIITHROW_TOKEN",
    )
    parser.add_argument("--token-file", metavar="FILE", help="read the operator token from FILE")
    parser.add_argument(
        "--allow-host",
        action="append",
        default=[],
        metavar="NAME",
        help="a further name the dashboard answers to (the browser's Host), e.g. robot-lab.local; repeatable",
    )
    parser.add_argument(
        "--max-guests",
        type=_guests,
        default=16,
        metavar="N",
        help="guest connections at once (default 16; 0: operators only); more are refused with 503",
    )


def add_scene_argument(parser: argparse.ArgumentParser) -> None:
    """`--plain-scene`: the dashboard's 3D scene without shadows or reflections (`web.scene.plain_lighting`),
    its progress bar without moving stripes (`web.panels.Panels`)."""
    parser.add_argument(
        "--plain-scene",
        action="store_true",
        help="draw the 3D scene without shadows or reflections and the progress bar without moving stripes, "
        "for a browser that renders in software (no GPU, a remote desktop), where they cost the most CPU",
    )


def check_port_free(host: str, port: int) -> None:
    """PortTaken (one line, exit 2) when `port` on `host` is taken, before anything slow starts;
    port 0 asks for any free port. (The dashboard checks again once viser has bound it.)"""
    if port == 0:
        return
    import errno
    import socket

    from wiithrow.web.handshake import PortTaken

    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds: TIME_WAIT is free
        try:
            probe.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise PortTaken(port) from None
            # another failure (an address this machine does not have) is the server's to report


def add_train_to_argument(parser: argparse.ArgumentParser) -> None:
    """`--train-to FILE`: where the dashboard's Training panel writes the library it trains."""
    parser.add_argument(
        "--train-to",
        metavar="LIBRARY.json",
        help="a file the Training panel also writes the library it trains to (it is always a new version of the "
        "library folder); its progress is kept beside it (LIBRARY.training.json) after every throw and resumed at "
        "start (default: trained.training.json in the library folder)",
    )


def train_to_from_args(args: argparse.Namespace, session: Session) -> None:
    """Point the session's training at `--train-to` (resuming a run saved beside it), if given."""
    if getattr(args, "train_to", None):
        session.train_to(args.train_to)


def _guests(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--max-guests takes a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"--max-guests takes 0 or more, got {value}")
    return value


def access_from_args(args: argparse.Namespace) -> Access:
    """The token (given or new) and host names; AppError for a bad token or an exposure without one.
    (`args` from a parser without `add_access_arguments`: a new token, no further names.)"""
    from wiithrow.web.access import refuse_exposure_without_token, resolve_token

    token = resolve_token(getattr(args, "token", None), getattr(args, "token_file", None))
    refuse_exposure_without_token(args.host, token)
    return Access(token, tuple(getattr(args, "allow_host", ())), getattr(args, "max_guests", 16))


class AutoCalibration:
    """The demo's automatic calibration of `poses` poses (none if 0): it waits for the first
    operator's page (`Clients.operator_seen`; a guest's does not count), so that the page shows
    it from its first pose, then starts once, as the Calibrate button does (an operator who
    pressed Calibrate meanwhile is not overruled: it is refused as busy, and not retried). The
    terminal is told (`say`) that it waits and when it starts."""

    def __init__(self, dashboard: Dashboard, poses: int, say: Callable[[str], None]) -> None:
        self.dashboard, self.poses, self.say = dashboard, int(poses), say
        self.waiting = self.poses > 0
        self.started = False
        if self.waiting:
            say(WAITING.format(poses=self.poses))

    def poll(self) -> bool:
        """Start the calibration if an operator's page has connected (once); True if it started now."""
        if not self.waiting or not self.dashboard.clients.operator_seen.is_set():
            return False
        self.waiting = False
        self.started = self.dashboard.start_calibration(self.poses)
        if self.started:
            self.say(f"wiithrow dashboard: an operator's page connected: calibrating ({self.poses} poses)")
        return self.started


#: What the start line says beside the operator's link.
GUESTS = "operator's link; guests (view only): the same address without the token; Ctrl-C to stop"


def start_line(dashboard: Dashboard) -> str:
    """The one line printed at start: the operator's link with its token (or, for a token read from
    a file or the environment, where it comes from), and the guests' address described, not linked."""
    if dashboard.access.token.printable:
        return f"wiithrow dashboard: {dashboard.operator_url}  ({GUESTS})"
    return f"wiithrow dashboard: {dashboard.url}?token=<the token from {dashboard.access.token.source}>  ({GUESTS})"


def run_dashboard(
    session: Session,
    *,
    host: str,
    port: int,
    access: Access | None = None,
    default_poses: int = DEFAULT_POSES,
    calibrate_poses: int = 0,
    duration: float | None = None,
    record: Path | None = None,
    plain_scene: bool = False,
) -> int:
    """Serve `session` with the dashboard until Ctrl-C (or `duration` s): print the address (and
    what an address beyond loopback means), start a calibration of `calibrate_poses` poses if
    > 0 once an operator's page has connected; at the end stop the arm, let the running operation end, close everything. `record`: record
    the session to this MCAP file from the start (`wiithrow.app.recording`). `plain_scene`: the
    scene without shadows or reflections (`add_scene_argument`)."""
    from wiithrow.web.access import LOG, exposure_note, is_local_host
    from wiithrow.web.limits import Limits
    from wiithrow.web.server import Dashboard

    access = access or Access()
    log = logging.StreamHandler(sys.stderr)
    log.setFormatter(logging.Formatter("wiithrow dashboard: %(message)s"))
    LOG.addHandler(log)
    try:
        dashboard = Dashboard(
            session,
            host=host,
            port=port,
            token=access.token,
            allow_hosts=access.allow_hosts,
            default_poses=default_poses,
            limits=Limits(max_guests=access.max_guests),
            plain_scene=plain_scene,
        )
    except BaseException:  # a taken port, an unsupported viser: the session was never served
        session.close()
        LOG.removeHandler(log)
        raise
    from wiithrow.web.recording_toggle import RecordToggle

    recorder = None
    if record is not None:
        from wiithrow.app.recording.session import SessionRecorder

        recorder = SessionRecorder(session, record)
        recorder.begin()
    # the Record button's files go beside --record's, else into ./recordings
    toggle = RecordToggle(dashboard, record.parent if record is not None else Path("recordings"), recorder)
    from wiithrow.web.learning_toggle import LearningToggle

    LearningToggle(dashboard)  # the Throw folder's Keep learning box
    from wiithrow.web.source_panel import source_panel

    sources = source_panel(dashboard)  # serve --markers-from: the publisher the operator follows
    with frozen_heap():  # what start-up built is never walked by a full collection while serving
        try:
            dashboard.start()
            print(start_line(dashboard), flush=True)
            if not is_local_host(host):
                print(exposure_note(host, dashboard.port), file=sys.stderr, flush=True)
            automatic = AutoCalibration(dashboard, calibrate_poses, say=lambda line: print(line, flush=True))
            end = None if duration is None else time.monotonic() + duration
            while end is None or time.monotonic() < end:
                automatic.poll()
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass
        finally:
            session.stop()
            dashboard.runner.join(timeout=5.0)
            if sources is not None:
                sources.close()
            dashboard.close()
            toggle.close()
            session.close()
            LOG.removeHandler(log)
    return 0
