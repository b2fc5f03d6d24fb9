"""`--publish` on the command line: a command's rig (and session) published over Zenoh.

`add_publish_arguments` gives a command `--publish`, `--rig-name`, `--zenoh-config`,
`--insecure-network` (and, for `track`, `--wait-subscriber`); `check_publish_arguments` refuses the
Zenoh flags without `--publish`, and `check_zenoh_config_arguments` --insecure-network without
--zenoh-config; `open_zenoh` opens the session the flags describe. `Publishing` starts the
`wiithrow.app.channels.zenoh_sink.ZenohProcessPublisher` (the Zenoh session and a `RigPublisher`
in a writer process; a bad config file is one line, exit 2) and has it follow a source (each event
packed into its ring on the rig's thread); `publish_session` publishes a running session's rig
and its throws (`wiithrow.app.recording.session_feed.follow_session`) until closed. `MarkersFrom` opens the Zenoh session and the marker source of `serve
--markers-from`. Whoever opens them closes them; the summary of what was sent or received goes to
stderr.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from wiithrow.app.channels.zenoh_sink import ZenohProcessPublisher, tell_failure
from wiithrow.app.cli.arguments import non_negative_float, refuse_flags
from wiithrow.app.errors import AppError
from wiithrow.app.network.messages import DEFAULT_RIG
from wiithrow.app.network.zenoh_session import add_zenoh_arguments, check_exposure, load_config, open_session

if TYPE_CHECKING:
    from wiithrow.app.rig.source import MarkerSource
    from wiithrow.app.session import Session
    from wiithrow.app.settings import Settings
    from wiithrow.clock import Clock

#: The flags that mean nothing without --publish.
ZENOH_FLAGS = ("rig_name", "zenoh_config", "insecure_network", "wait_subscriber")


def add_publish_arguments(parser: argparse.ArgumentParser, *, wait: bool = False, markers_from: bool = False) -> None:
    """The Zenoh flags, in one group; `--wait-subscriber` with `wait`, `--markers-from` with `markers_from`."""
    group = add_zenoh_arguments(parser)
    if wait:
        group.add_argument(
            "--wait-subscriber",
            type=non_negative_float,
            default=None,
            metavar="SECONDS",
            help="with --publish: wait up to SECONDS for a subscriber of the markers before starting (default: 0)",
        )
    if markers_from:
        group.add_argument(
            "--markers-from",
            metavar="PREFIX",
            default=None,
            help="take the tracked markers another host publishes under PREFIX (e.g. wiithrow/lab, from "
            "`wiithrow track --publish --rig-name lab` there) instead of reading remotes here",
        )
        group.add_argument(
            "--markers-source",
            metavar="ZENOH_ID",
            default=None,
            help="with --markers-from: follow the publisher of this Zenoh session id from its first frame, and no "
            "other (what `track --publish` announces as its source; fixed by the `id` of the tracking host's Zenoh "
            "config); default: none until the operator confirms one on the dashboard (Marker source). A restarted "
            "publisher is confirmed there again",
        )


def check_publish_arguments(args: argparse.Namespace) -> None:
    if not getattr(args, "publish", False):
        refuse_flags(args, ZENOH_FLAGS, "without --publish")
    check_zenoh_config_arguments(args)


def check_zenoh_config_arguments(args: argparse.Namespace) -> None:
    """--insecure-network means nothing without --zenoh-config (the default never leaves loopback);
    a config that is bad or reaches past loopback unauthenticated is refused before the command's
    work starts (a simulated rig takes seconds to build)."""
    config_file = getattr(args, "zenoh_config", None)
    insecure = getattr(args, "insecure_network", False)
    if insecure and config_file is None:
        raise AppError(
            "--insecure-network does not apply without --zenoh-config (without one, Zenoh stays on this host's loopback)"
        )
    if config_file is not None and not insecure:  # (with --insecure-network, open_session warns once)
        check_exposure(load_config(config_file), config_file, insecure_network=False)


def open_zenoh(args: argparse.Namespace) -> Any:
    """The Zenoh session of `args.zenoh_config` (None: this host's loopback), checked as `open_session` says."""
    return open_session(getattr(args, "zenoh_config", None), insecure_network=getattr(args, "insecure_network", False))


class Publishing:
    """The rig's publisher, its Zenoh session in a writer process (`ZenohProcessPublisher`), on the
    rig's `clock`; `close()` ends it and says what was sent."""

    def __init__(
        self, args: argparse.Namespace, command: str, camera_names: Sequence[str], frame_name: str, clock: Clock
    ) -> None:
        self.command = command
        # the session and the puts live in a writer process: the rig's thread only hands frames over
        self.publisher = ZenohProcessPublisher(
            args.rig_name or DEFAULT_RIG,
            camera_names,
            frame_name,
            clock=clock,
            config_file=getattr(args, "zenoh_config", None),
            insecure_network=getattr(args, "insecure_network", False),
            on_failure=tell_failure(command),
        )
        self._stop_feed: Callable[[], None] | None = None
        print(f"wiithrow {command}: {self.publisher.announcement()}", file=sys.stderr, flush=True)
        wait = getattr(args, "wait_subscriber", None)
        if wait and not self.publisher.wait_for_subscribers(wait):
            print(f"wiithrow {command}: no subscriber after {wait:g} s: publishing anyway", file=sys.stderr, flush=True)

    def follow(self, source: MarkerSource) -> None:
        """Publish what `source` tracks and reads from now on, packed on its own thread as it tells it."""
        self.publisher.follow(source)

    def watch(self, session: Session) -> None:
        """Publish `session`'s rig (on the rig loop's thread) and its throws, until `close`."""
        from wiithrow.app.recording.session_feed import follow_session

        self._stop_feed = follow_session(self.publisher, session, arm=False)

    def close(self) -> None:
        if self._stop_feed is not None:
            self._stop_feed()
        self.publisher.close()
        print(f"wiithrow {self.command}: {self.publisher.summary()}", file=sys.stderr, flush=True)


def publish_session(args: argparse.Namespace, command: str, session: Session) -> Publishing | None:
    """With --publish: publish `session` (its world's rig and throws) until the result is closed.
    (The command has checked its flags: `check_publish_arguments`.)"""
    if not getattr(args, "publish", False):
        return None
    publishing = Publishing(args, command, session.world.rig.camera_names, "link1", session.world.clock)
    publishing.watch(session)
    return publishing


def check_markers_from_arguments(args: argparse.Namespace) -> None:
    """With --markers-from: refuse what belongs to the host that tracks; else the --publish checks."""
    if getattr(args, "markers_from", None) is None:
        refuse_flags(args, ("markers_source",), "without --markers-from")
        check_publish_arguments(args)
        return
    named = getattr(args, "markers_source", None)
    if named is not None and not re.fullmatch(r"[0-9a-f]{1,32}", named):
        raise AppError(f"--markers-source is a Zenoh id (1-32 lowercase hex digits), not {named!r}")
    check_zenoh_config_arguments(args)
    refuse_flags(
        args,
        ("calibration", "publish", "rig_name", "wait_subscriber"),
        "with --markers-from (the host that publishes the markers tracks them, with its calibration)",
    )


class MarkersFrom:
    """A Zenoh session and the markers it brings (`wiithrow.app.worlds.remote.markers_from`), the
    source a world is built with; the source's notices (whom it follows, who asks to be followed,
    the markers turning stale, the refusals summed up) go to stderr and, once `tell` names a session, to its status message; `close()`
    ends both and says how many frames came, with their latency, and how many were refused, by
    reason."""

    def __init__(self, args: argparse.Namespace, command: str, settings: Settings, clock: Clock) -> None:
        from wiithrow.app.worlds.remote import markers_from

        self.command = command
        self.zenoh_session = open_zenoh(args)
        try:
            self.rig = markers_from(
                self.zenoh_session,
                args.markers_from,
                settings,
                clock,
                named_source=getattr(args, "markers_source", None),
            )
        except BaseException:
            self.zenoh_session.close()
            raise
        self.rig.notices.subscribe(self._print_notice)
        print(
            f"wiithrow {command}: markers from {self.rig.prefix}/markers over Zenoh (the remotes are there)",
            file=sys.stderr,
            flush=True,
        )

    def _print_notice(self, notice: str) -> None:
        print(f"wiithrow {self.command}: {notice}", file=sys.stderr, flush=True)

    def tell(self, session: Session) -> None:
        """Show the source's notices as `session`'s status message too (the dashboard's)."""
        self.rig.notices.subscribe(session.tell)

    def summary(self) -> str:
        latency = self.rig.latency_ms()
        text = f"received {self.rig.received} marker frames from {self.rig.prefix}"
        if latency:
            text += (
                f", latency p50 {latency['p50_ms']:.2f} ms, p99 {latency['p99_ms']:.2f} ms "
                "(the two hosts' clocks: exact on one machine)"
            )
        text += f"; adopted {self.rig.adopted}, refused {self.rig.refusal_counts()}"
        if self.rig.dots_refused:
            text += f" ({self.rig.dots_refused} camera frames refused: not the followed source's, or malformed)"
        return text

    def close(self) -> None:
        self.rig.close()
        self.zenoh_session.close()
        print(f"wiithrow {self.command}: {self.summary()}", file=sys.stderr, flush=True)
