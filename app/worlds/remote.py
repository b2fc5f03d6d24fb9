"""Worlds whose rig's markers come over Zenoh from another host (`serve --markers-from`).

`markers_from(world, session, prefix)` replaces a world's rig by a
`wiithrow.app.network.remote_rig.RemoteRig`: the remotes are near the rig on another host, which
tracks them (`track --publish`), and this host runs the arm, the session and the dashboard on the
frames that arrive. The world's own drivers only name the cameras (`far_drivers`); they are never
opened.

`simulated_loopback(world, publish_session, subscribe_session, rig_name)` closes that path in a
simulated world: its own simulated remotes are tracked and published as the far host would publish
them (`RigPublisher` on `publish_session`), and the session reads the frames back through Zenoh
(`subscribe_session`; two sessions connected over loopback in the tests), waiting for each
published frame to arrive, so that alignment and throws run on markers that crossed Zenoh, and
their latency is measured (`RemoteRig.latency_ms`).
"""

from __future__ import annotations

from typing import Any

from wiithrow.app.network.messages import rig_prefix
from wiithrow.app.network.publisher import DotsFollower, RigPublisher
from wiithrow.app.network.remote_rig import RemoteRig
from wiithrow.app.worlds.base import RigWorld
from wiithrow.clock import Clock
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.transport import Transport


def _on_the_far_host() -> Transport:
    raise OSError("the remotes are on the host that publishes the markers (--markers-from)")


def far_drivers(count: int, clock: Clock) -> list[WiimoteDriver]:
    """Drivers that only name `count` cameras (cam0, ...): they are never opened here."""
    return [WiimoteDriver(_on_the_far_host, clock, name=f"cam{c}") for c in range(count)]


def markers_from(world: RigWorld, session: Any, prefix: str) -> RemoteRig:
    """Make `world` read its markers from `prefix` (e.g. `wiithrow/lab`) on `session`; the new rig."""
    Ps = world.calibration.Ps if world.calibration is not None else world.true_calibration_Ps()
    rig = RemoteRig(session, prefix, world.rig.drivers, Ps, world.clock)
    world.rig = rig
    return rig


def simulated_loopback(world: RigWorld, publish_session: Any, subscribe_session: Any, rig_name: str) -> RemoteRig:
    """`world`'s rig, tracked and published on one session and read back on the other (see above).
    The world must be tracking (calibrated) already."""
    local = world.rig
    if local.tracker is None or world.calibration is None:
        raise ValueError("simulated_loopback needs a calibrated world")
    publisher = RigPublisher(publish_session, rig_name, [d.name for d in local.drivers], world.calibration.frame)
    dots = DotsFollower(publisher, local)

    def publish_what_the_rig_tracks() -> int:
        frames = local.poll()
        for frame in frames:
            publisher.publish_markers(frame)
        dots.publish_new()
        return len(frames)

    rig = RemoteRig(
        subscribe_session,
        rig_prefix(rig_name),
        local.drivers,
        world.calibration.Ps,
        world.clock,
        source=publish_what_the_rig_tracks,
        settle_s=1.0,
        local=local,
    )
    world.rig = rig
    return rig
