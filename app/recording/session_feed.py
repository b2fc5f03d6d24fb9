"""`SessionFeed`: what a session tells its channels beside its rig's, for every sink alike;
`follow_session`: a sink in a writer process following a session.

A recording (`SessionRecorder`), Foxglove live, the ROS 2 and the Zenoh publishers of a session
take the same messages from here, built once (`wiithrow.app.channels.json_messages`), each handed
to the sink's `write(topic, stamp_ns, message)`:

- the arm's URDF (`/robot_description`, latched), when the feed starts;
- each previewed throw's commanded trajectory (`/arm/trajectory`), on the thread that tells the
  session's event;
- each throw's document (`/throws`, `throw_document`: its index, joint 1, its outcome and its
  release), on a throw and again when its landing is measured since (Measure landing);
- the arm's state for the rig's thread to sample (`arm_state`: its joints and base -> link1), what
  `/arm/joints` and `/tf` carry (`wiithrow.app.channels.sink_process.ArmSampler`: at most 50 Hz,
  where a camera's frames were processed).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.channels import json_messages as jm
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.rig_messages import Write
from wiithrow.app.channels.sink_process import SinkProcess
from wiithrow.app.channels.wall_time import WallTime
from wiithrow.app.session import Event, Session, ThrowRecord
from wiithrow.vision.files import dumps_strict


def throw_document(record: ThrowRecord) -> dict[str, Any]:
    """A throw as every sink carries it: its `index`, joint 1's angle `q1`, its `outcome`
    (`ThrowRecord.to_dict`) and its `release` (time, joints, the ball's position and velocity in
    base), as strict JSON (no NaN)."""
    ex = record.execution
    document = {
        "index": record.index,
        "q1": record.q1,
        "outcome": record.to_dict(),
        "release": {
            "t": ex.t_release,
            "q": ex.release.q,
            "dq": ex.release.dq,
            "position_base_m": ex.release.position,
            "velocity_base_m_s": ex.release.velocity,
        },
    }
    result: dict[str, Any] = json.loads(dumps_strict(document))
    return result


class SessionFeed:
    """`session`'s messages to `write`, stamped with `wall` (module docstring), from `start()` to `stop()`."""

    def __init__(self, session: Session, write: Write, wall: WallTime) -> None:
        self.session = session
        self.write = write
        self.wall = wall
        world = session.world
        self.joint_names = list(world.arm_model.joint_names)
        self._throws_seen = len(session.history)

    def start(self) -> None:
        """Say the robot's description, and listen to the session's events."""
        urdf = self.urdf()
        if urdf is not None:
            now = self.session.world.clock.now()
            self.write(r.ROBOT_DESCRIPTION.topic, self.wall.stamp_ns(now), jm.robot_description_message(urdf))
        self._throws_seen = len(self.session.history)
        self.session.subscribe(self._event)

    def stop(self) -> None:
        self.session.unsubscribe(self._event)

    def urdf(self) -> str | None:
        """The arm's URDF, as its file says (None: a model built without one, or unreadable)."""
        path = self.session.world.arm_model.urdf_path
        try:
            return None if path is None else path.read_text()
        except OSError:
            return None

    def arm_state(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The arm now: q, dq (rad, rad/s) and base -> link1 (4x4)."""
        world = self.session.world
        state = world.arm.state()
        T = world.arm_model.frame_placement(state.q, "link1")
        return np.asarray(state.q, dtype=float), np.asarray(state.dq, dtype=float), np.asarray(T, dtype=float)

    def _event(self, event: Event) -> None:
        t = self.session.world.clock.now()
        stamp_ns = self.wall.stamp_ns(t)
        if event is Event.PREVIEW and self.session.preview is not None:
            preview = self.session.preview
            trajectory = preview.throw.trajectory
            message = jm.trajectory_message(
                t, self.joint_names, trajectory.times, trajectory.positions, f"throw preview {preview.id}"
            )
            self.write(r.TRAJECTORY.topic, stamp_ns, message)
        elif event is Event.THROW:
            history = self.session.history
            # a new throw, or the last one's landing measured since (Measure landing)
            for record in history[min(self._throws_seen, len(history) - 1) :] if history else []:
                self.write(r.THROWS.topic, stamp_ns, jm.throw_message(t, throw_document(record)))
            self._throws_seen = len(history)


def follow_session(sink: SinkProcess, session: Session, *, arm: bool = True) -> Callable[[], None]:
    """`sink` follows `session`: its rig's events and (with `arm`) its arm, on the rig's thread, and
    its messages (`SessionFeed`, through the sink's sender); what is returned stops the messages
    (the sink's `close` stops the rest)."""
    feed = SessionFeed(session, sink.post, sink.wall)
    sink.follow(session.world.rig, arm=feed.arm_state if arm else None)
    feed.start()
    return feed.stop
