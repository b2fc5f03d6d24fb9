"""`FoxglovePlayer`: a recording played to Foxglove, scrubbed on Foxglove's timeline.

foxglove-sdk's WebSocket server (the same as `live`: its own `foxglove.Context`, loopback unless
`check_host` lets another host in) advertising the recording's time range (`playback_time_range`,
which the SDK announces as `dataStartTime`/`dataEndTime` in `serverInfo`) and the `playbackControl`
and `time` capabilities: Foxglove then shows a player's timeline instead of a live view, and its
play, pause, seek and speed controls arrive as `PlaybackControlRequest`s (`_Listener`), each
answered with the `PlaybackState` that results (the SDK sends it to every client, with the
request's id).

What it serves is what the file holds, message for message (the recorded JSON, not re-encoded),
each with its recorded log time, on the live server's channels: the same topics and schemas
(`wiithrow.app.recording.channels.schema_of`), all advertised before the first client connects so
that a client can subscribe before it presses play. Topics this wiithrow has no schema for are
not served (`skipped_topics`).

The timeline (all times in ns on the recording's clock). A first pass over the file
(`read_timeline`) finds the range: the first and the last intact message. The position moves with
the wall clock at the speed while playing, `position = at + (wall - wall_at) * speed` (clamped to
`MIN_SPEED..MAX_SPEED` like the SDK's example player), and stands while paused; the loop (`run`)
logs every message whose log time is at or before the position and broadcasts the position as
the server's time at most every `TIME_EVERY_NS` of it. A seek to `T` (clamped to the range) is a
new pass over the file (`Recording.messages()`: bounded, a chunk at a time, as far as the file is
intact) from the last checkpoint at least `CHECKPOINT_MARGIN_NS` before `T` (the first pass keeps
one at a chunk's start every `CHECKPOINT_NS`: `Timeline.checkpoints`), so a seek reads a few
seconds of the file wherever `T` is: the messages from there to `T` are passed over (not parsed), keeping the last one of each state topic (`STATE_TOPICS`:
the frames, the markers, the calibration, the arm's URDF, each camera's dots, the arm's joints), which are sent
again stamped at `T` so that panels show the state at `T`; then the messages from `T` on (no
message with a log time before `T` is sent after a seek). Foxglove clears its panels on a state with
`did_seek`, so the state at `T` must reach it after that: the player broadcasts the `did_seek`
state itself as it takes the request (the SDK then sends the answer it returns, the same state
without `did_seek`, a second time), and the loop makes the pass `SEEK_SETTLE_NS` later (the SDK's
two queues: see there); nothing is sent in between. Seeks that come faster (a drag on the
timeline) make one pass, at the last one's time.

Without a client the player plays from the start at its speed and `run` returns at the end, as a
replay always did (`wait=False`); `wait=True` (`replay --foxglove-wait`) starts paused, for a
client to press play, and keeps serving after the end (a seek plays again) until `close()`.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from typing import Any

from wiithrow.app.channels import json_schemas
from wiithrow.app.channels.foxglove_sink import DEFAULT_PORT, LOOPBACK, check_host
from wiithrow.app.errors import AppError
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.reading import MessageStream, RecordedMessage, Recording, Resume

#: Speeds a client may ask for (as the SDK's example player clamps them): x0.01 to x100.
MIN_SPEED, MAX_SPEED = 0.01, 100.0
#: How often the position is broadcast as the server's time: every 1/60 s of the recording.
TIME_EVERY_NS = 1_000_000_000 // 60
#: Topics whose last message is what a panel shows until the next (re-sent at a seek's time).
STATE_TOPICS = (ch.CALIBRATION, ch.TF, ch.TF_STATIC, ch.ROBOT_DESCRIPTION, ch.MARKERS, ch.MARKERS_SCENE, ch.JOINTS)
#: The most messages logged in one turn of the loop (holding the lock): a client's request waits
#: at most that long when the loop is behind.
_BATCH = 1000
#: A checkpoint (where a seek's pass may start) every 5 s of the recording or more, at a chunk's
#: start: a seek reads at most that, the margin and a chunk; each holds the state topics' last
#: messages (a few kB), so an hour's recording keeps about 700 (a few MB).
CHECKPOINT_NS = 5_000_000_000
#: A seek starts at a checkpoint at least 1 s before its time, for a message written in an earlier
#: chunk with a later log time than a later chunk's first (the rig writes what it tracked after the
#: reports it came from).
CHECKPOINT_MARGIN_NS = 1_000_000_000
#: How long after a seek's `did_seek` state the state at the seek's time is sent: the SDK sends a
#: client's control and data messages from two queues, taking from either when both hold one, so
#: a data message queued right after the state may overtake it (and be cleared with the panels);
#: 50 ms lets the state go first (not a certainty on a machine too loaded to run the SDK's thread
#: for that long; then a panel shows the seek's time from its topic's next message), and is
#: short against a click on the timeline.
SEEK_SETTLE_NS = 50_000_000
#: The longest the loop sleeps at once: how late it sees a close when nothing wakes it.
_NAP_S = 0.1


def is_state_topic(topic: str) -> bool:
    return topic in STATE_TOPICS or topic.endswith("/dots")


def clamp_speed(speed: float) -> float:
    """A client's speed within `MIN_SPEED..MAX_SPEED` (NaN: the slowest)."""
    if math.isnan(speed):
        return MIN_SPEED
    return min(max(speed, MIN_SPEED), MAX_SPEED)


@dataclass(frozen=True)
class Checkpoint:
    """Where a seek's pass may start: a chunk (`resume`) whose first message is at `time` (ns), and
    the last message of each state topic before that chunk."""

    time: int
    resume: Resume
    state: dict[str, RecordedMessage]


@dataclass(frozen=True)
class Timeline:
    """A recording's range (ns: its first and last intact message), its topics in first-seen order,
    where a damaged file ends (None: intact), and its checkpoints in file order."""

    start: int
    end: int
    topics: tuple[str, ...]
    damage: str | None
    checkpoints: tuple[Checkpoint, ...]

    def checkpoint_before(self, t: int) -> Checkpoint | None:
        """The last checkpoint `CHECKPOINT_MARGIN_NS` or more before `t` (None: the file's start)."""
        found = None
        for checkpoint in self.checkpoints:
            if checkpoint.time > t - CHECKPOINT_MARGIN_NS:
                break
            found = checkpoint
        return found


def read_timeline(recording: Recording) -> Timeline:
    """One pass over the file: its range, topics and checkpoints (a chunk every `CHECKPOINT_NS` or
    more; `AppError` for a file with no message)."""
    start: int | None = None
    end: int | None = None
    topics: dict[str, None] = {}
    state: dict[str, RecordedMessage] = {}
    checkpoints: list[Checkpoint] = []
    with recording.messages() as stream:
        chunk = stream.resume_point
        for message in stream:
            if stream.resume_point is not chunk:  # the first message of a chunk
                chunk = stream.resume_point
                last = checkpoints[-1].time if checkpoints else start
                if chunk is not None and last is not None and message.log_time >= last + CHECKPOINT_NS:
                    checkpoints.append(Checkpoint(message.log_time, chunk, dict(state)))
            start = message.log_time if start is None else min(start, message.log_time)
            end = message.log_time if end is None else max(end, message.log_time)
            topics.setdefault(message.topic)
            if is_state_topic(message.topic):
                state[message.topic] = message
        damage = stream.end
    if start is None or end is None:
        raise AppError(f"{recording.path}: no message to play" + (f" ({damage})" if damage else ""))
    return Timeline(start, end, tuple(topics), damage, tuple(checkpoints))


class FoxglovePlayer:
    """`recording` played to Foxglove on `host`:`port` (0: a free one) with Foxglove's timeline
    (module docstring); `run()` plays, `close()` stops. `speed`: the starting speed (a client sets
    its own). `host` beyond loopback only with `insecure_network` (`check_host`)."""

    def __init__(
        self,
        recording: Recording,
        *,
        port: int = DEFAULT_PORT,
        host: str = LOOPBACK,
        insecure_network: bool = False,
        speed: float = 1.0,
        wait: bool = False,
    ) -> None:
        import foxglove
        from foxglove.websocket import Capability, PlaybackStatus

        check_host(host, insecure_network=insecure_network)
        self.recording = recording
        self.host = host
        self.timeline = read_timeline(recording)
        self.wait = wait
        self.logged = 0  # messages logged to a channel (state re-sent at seeks included)
        self.end: str | None = self.timeline.damage
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._closed = False
        self._Status = PlaybackStatus
        self._status = PlaybackStatus.Paused if wait else PlaybackStatus.Playing
        self._speed = clamp_speed(speed)
        self._at = self.timeline.start  # the position at `_wall_at` (ns of the recording)
        self._wall_at = time.monotonic_ns()
        self._seek_to: int | None = self.timeline.start  # a pass the loop opens at `_seek_due`
        self._seek_due = 0  # monotonic ns
        self._floor = self.timeline.start  # no message before this is sent (the last seek's time)
        self._stream: MessageStream | None = None
        self._pending: RecordedMessage | None = None
        self._time_sent: int | None = None
        self._context = foxglove.Context()
        self._channels: dict[str, Any] = {}
        self.skipped_topics: list[str] = []
        for topic in self.timeline.topics:
            try:
                name = ch.schema_of(topic)
            except KeyError:  # a topic of a newer wiithrow: no schema to serve it with
                self.skipped_topics.append(topic)
                continue
            schema = foxglove.Schema(name=name, encoding="jsonschema", data=json_schemas.schema_bytes(name))
            self._channels[topic] = foxglove.Channel(
                topic, schema=schema, message_encoding="json", context=self._context
            )
        try:
            self._server = foxglove.start_server(
                name=f"wiithrow replay {recording.path.name}",
                host=host,
                port=port,
                capabilities=[Capability.PlaybackControl, Capability.Time],
                server_listener=_listener(self),
                playback_time_range=(self.timeline.start, self.timeline.end),
                context=self._context,
            )
        except Exception as exc:  # the port is taken, most often
            raise AppError(f"--foxglove: cannot serve on {host}:{port}: {exc}") from None
        self.port = int(self._server.port)

    @property
    def speed(self) -> float:
        """The speed the player plays at (a client may have set it)."""
        return self._speed

    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    # The position on the timeline (the lock held).

    def _position(self, wall: int) -> int:
        if self._status != self._Status.Playing:
            return self._at
        return min(self.timeline.end, self._at + round((wall - self._wall_at) * self._speed))

    def _anchor(self, wall: int) -> None:
        self._at = self._position(wall)
        self._wall_at = wall

    def _state(self, *, did_seek: bool, request_id: str | None) -> Any:
        from foxglove.websocket import PlaybackState

        return PlaybackState(
            status=self._status,
            current_time=self._at,
            playback_speed=self._speed,
            did_seek=did_seek,
            request_id=request_id,
        )

    def control(self, request: Any) -> Any:
        """A client's `PlaybackControlRequest` applied: the `PlaybackState` that results."""
        from foxglove.websocket import PlaybackCommand

        with self._lock:
            self._anchor(time.monotonic_ns())
            did_seek = request.seek_time is not None
            if did_seek:
                self._at = min(max(int(request.seek_time), self.timeline.start), self.timeline.end)
                self._seek_to = self._at
                self._seek_due = time.monotonic_ns() + SEEK_SETTLE_NS
                if self._status == self._Status.Ended:
                    self._status = self._Status.Paused
            self._speed = clamp_speed(float(request.playback_speed))
            if self._status != self._Status.Ended:  # from the end, only a seek plays again
                playing = request.playback_command == PlaybackCommand.Play
                self._status = self._Status.Playing if playing else self._Status.Paused
            state = self._state(did_seek=did_seek, request_id=request.request_id)
            if did_seek:  # queued before the state at T (`SEEK_SETTLE_NS`)
                self._server.broadcast_playback_state(state)
                state = self._state(did_seek=False, request_id=request.request_id)
        self._wake.set()
        return state

    # The loop.

    def run(self) -> None:
        """Play until the end (`wait`: until `close()`), as the clients ask."""
        with self._lock:
            self._wall_at = time.monotonic_ns()  # the position starts moving now
        while True:
            with self._lock:
                if self._closed:
                    return
                settle = (self._seek_due - time.monotonic_ns()) / 1e9
                if self._seek_to is not None and settle <= 0:
                    self._open_at(self._seek_to)
                    self._seek_to = None
                    self._wall_at = time.monotonic_ns()  # from the seek's time on, after its pass
                nap = self._turn() if self._seek_to is None else settle
                if nap is None:
                    return
            self._wake.wait(nap)
            self._wake.clear()

    def _turn(self) -> float | None:
        """Log what is due; how long to sleep (None: the end, and not `wait`)."""
        if self._status != self._Status.Playing:
            return _NAP_S
        wall = time.monotonic_ns()
        position = self._position(wall)
        for _ in range(_BATCH):
            message = self._peek()
            if message is None:
                self._ended(wall)
                return _NAP_S if self.wait else None
            if message.log_time > position:
                self._broadcast_time(position)
                return min(_NAP_S, (message.log_time - position) / self._speed / 1e9)
            self._pending = None
            if message.log_time >= self._floor:
                self._log(message.topic, message.data, message.log_time)
        self._broadcast_time(position)
        return 0.0

    def _ended(self, wall: int) -> None:
        self._anchor(wall)
        self._at = self.timeline.end
        self._status = self._Status.Ended
        self._broadcast_time(self._at, force=True)
        self._server.broadcast_playback_state(self._state(did_seek=False, request_id=None))

    def _peek(self) -> RecordedMessage | None:
        if self._pending is None and self._stream is not None:
            self._pending = next(self._stream, None)
            if self._pending is None:
                self.end = self.end or self._stream.end
                self._stream.close()
                self._stream = None
        return self._pending

    def _open_at(self, t: int) -> None:
        """A new pass from the file's start to `t`: the state at `t` sent, stamped `t` (module docstring)."""
        if self._stream is not None:
            self._stream.close()
        checkpoint = self.timeline.checkpoint_before(t)
        self._stream = self.recording.messages(resume=checkpoint.resume if checkpoint else None)
        self._pending = None
        self._floor = t
        state = dict(checkpoint.state) if checkpoint else {}
        while (message := self._peek()) is not None and message.log_time < t:
            self._pending = None
            if is_state_topic(message.topic):
                state[message.topic] = message
        for message in sorted(state.values(), key=lambda m: m.log_time):
            self._log(message.topic, message.data, t)
        self._broadcast_time(t, force=True)

    def _log(self, topic: str, data: bytes, log_time: int) -> None:
        channel = self._channels.get(topic)
        if channel is not None:
            channel.log(data, log_time=log_time)
            self.logged += 1

    def _broadcast_time(self, t: int, *, force: bool = False) -> None:
        if force or self._time_sent is None or abs(t - self._time_sent) >= TIME_EVERY_NS:
            self._server.broadcast_time(t)
            self._time_sent = t

    def close(self) -> None:
        """Stop playing and serving (from any thread: `run` returns)."""
        with self._lock:
            self._closed = True
            if self._stream is not None:
                self._stream.close()
                self._stream = None
        self._wake.set()
        self._server.stop()


def _listener(player: FoxglovePlayer) -> Any:
    """foxglove-sdk's `ServerListener` for `player`: it answers the clients' playback controls (the
    other hooks are the protocol's defaults: this server advertises no other client capability)."""
    from foxglove.websocket import ServerListener

    class Listener(ServerListener):
        def on_playback_control_request(self, playback_control_request: Any) -> Any:
            return player.control(playback_control_request)

    return Listener()
