"""Worlds whose rig's markers come over Zenoh from another host (`serve --markers-from`).

A world is built with its marker source; these build the remote one
(`wiithrow.app.network.remote_rig.RemoteRig`):

* `markers_from(zenoh_session, prefix, settings, clock)`: the source of a `HardwareWorld` whose
  remotes are near the rig on another host, which tracks them (`track --publish`): this host runs
  the arm, the session and the dashboard on the frames that arrive, with no remote and no driver
  of its own (`HardwareWorld(settings, source=...)`);
* `simulated_loopback(publish_session, subscribe_session, rig_name)`: what a simulated world
  gives as its `markers` to close that path in simulation: its own simulated remotes are tracked
  (with the world's calibration, else the true one) and published as the far host would publish
  them (`RigPublisher` on `publish_session`, a `RigFollower` put after each poll), and the world
  reads the frames back through Zenoh (`subscribe_session`; two sessions connected over loopback
  in the tests), waiting for each published frame to arrive, so that alignment and throws run on
  markers that crossed Zenoh, and their latency is measured (`RemoteRig.latency_ms`); only its
  own publisher's Zenoh id is followed (`named_source`), as `serve --markers-source` would; its
  frames are signed with this user's secret, as every publisher's.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from wiithrow.app.channels.follower import RigFollower
from wiithrow.app.channels.zenoh_sink import RigPublisher
from wiithrow.app.network.messages import rig_prefix
from wiithrow.app.network.remote_rig import RemoteRig
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.base import RigWorld, nominal_cameras
from wiithrow.clock import Clock


def markers_from(
    zenoh_session: Any, prefix: str, settings: Settings, clock: Clock, *, named_source: str | None = None
) -> RemoteRig:
    """The markers of `prefix` (e.g. `wiithrow/lab`) on `zenoh_session`, for a rig of the settings'
    cameras (their nominal calibration names them, stands for the far host's and bounds the volume
    a marker may be in); only from the Zenoh id `named_source` when given (its first stream followed
    at once), else from the publisher the operator confirms (`RemoteRig.adopt`)."""
    cameras = nominal_cameras(settings.rig)
    Ps = np.stack([c.P for c in cameras])
    return RemoteRig(zenoh_session, prefix, [c.name for c in cameras], Ps, clock, named_source=named_source)


def simulated_loopback(publish_session: Any, subscribe_session: Any, rig_name: str) -> Callable[[RigWorld], RemoteRig]:
    """A simulated world's `markers`: its rig tracked and published on one session and read back
    on the other (see the module docstring)."""

    def loopback(world: RigWorld) -> RemoteRig:
        local = world.rig
        if world.calibration is None:
            world.set_calibration(world.true_calibration())  # the far host tracks with the truth
        assert world.calibration is not None and local.Ps is not None
        publisher = RigPublisher(publish_session, rig_name, local.camera_names, world.calibration.frame)
        follower = RigFollower(publisher, local)
        follower.start()

        def publish_what_the_rig_tracks() -> int:
            before = publisher.markers_sent
            local.poll()
            follower.put_pending()
            return publisher.markers_sent - before

        return RemoteRig(
            subscribe_session,
            rig_prefix(rig_name),
            local.camera_names,
            local.Ps,
            world.clock,
            source=publish_what_the_rig_tracks,
            settle_s=1.0,
            local=local,
            named_source=publisher.sender.source,  # the world knows its publisher: no other is followed
        )

    return loopback
