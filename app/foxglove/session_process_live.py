"""`FoxgloveSessionProcessLive`: Foxglove live for a session, its server and encoding in a writer process.

What `demo`, `serve` and `replay --dashboard` run with `--foxglove`. The channels, schemas and
messages a `SessionRecorder`'s file has, served by `FoxgloveProcessLive`'s writer process
(`wiithrow.app.channels.foxglove_writer`, `session` on):

- the rig's events, packed into the shared-memory ring on the rig's thread, and the arm, sampled
  where the recorder samples it (once a camera's frames were processed, at most every
  `ARM_PERIOD_S` of the world's clock; about 10 us: `state()` and the base -> link1 placement):
  one `ARM` record, which the child writes as `/arm/joints` and `/tf`; both skipped while no
  client is subscribed (`SinkProcess.follow`);
- the session's messages (its URDF, a previewed throw's trajectory, each throw and its landing):
  built by `SessionFeed`, the recorder's own, on the thread that tells the event (the session's),
  and handed to the child by the sink process's sender thread (`SinkProcess.post`: the session's
  thread never waits on the pipe; at most `QUEUE_MESSAGES` wait, one more is dropped and counted,
  `messages_dropped`).

A child that ends is one line on stderr; the rig and the session go on: the ring overwrites, and
a message to a child that is gone is dropped.
"""

from __future__ import annotations

from wiithrow.app.channels.foxglove_sink import DEFAULT_PORT, LOOPBACK, FoxgloveProcessLive
from wiithrow.app.recording.session_feed import follow_session
from wiithrow.app.session import Session


class FoxgloveSessionProcessLive(FoxgloveProcessLive):
    """A session's channels (its rig, arm and throws), live, on `host`:`port` (0: a free one),
    served by a writer process, until `close()` (module docstring; `host` beyond loopback only
    with `insecure_network`)."""

    def __init__(
        self,
        session: Session,
        *,
        port: int = DEFAULT_PORT,
        host: str = LOOPBACK,
        insecure_network: bool = False,
        command: str = "foxglove",
    ) -> None:
        self.session = session
        super().__init__(
            session.world.rig,
            port=port,
            frame_id="link1",
            host=host,
            insecure_network=insecure_network,
            command=command,
            session=True,
            joint_names=session.world.arm_model.joint_names,
            follow=False,
        )
        self._stop_feed = follow_session(self, session)

    def close(self) -> None:
        self._stop_feed()
        super().close()
