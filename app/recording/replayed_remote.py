"""`ReplayedRemote`: a recording's remote as a `Transport`, for the dashboard to watch a replay.

It answers a `WiimoteDriver` as a remote would, from a recording: it acknowledges every output
report it is sent (0x22) and answers a status request, and once the driver sets the reporting
mode it sends that camera's recorded IR reports at their recorded pace on the driver's clock, read
from the file as it goes (a pass per lap, nothing kept), from the start again when they run out (at the recorded pace only: the driver dates the reports of a
batch 10 ms apart, as a remote sends them). The driver, synchroniser and tracker
then run live on them (`wiithrow replay --dashboard`): the markers move as recorded, but the
reports are read in batches of this run, not the recorded ones, so the numbers are not the
recorded ones to the last digit (`Replay` gives those).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Generator

from wiithrow.app.recording.channels import CALIBRATION, RecordingError, reports_topic
from wiithrow.app.recording.reading import RecordedMessage, Recording
from wiithrow.clock import Clock
from wiithrow.vision import StereoCalibration
from wiithrow.vision.dlt import CalibratedCamera
from wiithrow.vision.wiimote.input_reports import encode_ack, encode_status
from wiithrow.vision.wiimote.protocol import OUT_REPORT_MODE, OUT_STATUS_REQUEST

IR_REPORTS = frozenset({0x33, 0x36, 0x37, 0x3E, 0x3F})


def recorded_ir_reports(recording: Recording, camera: int) -> Generator[tuple[float, bytes], None, None]:
    """Camera `camera`'s recorded IR reports with their receive times, in order: a pass over the
    file (closed when the generator is), to its intact part's end or the first report message
    that does not parse."""
    with recording.messages([reports_topic(camera)]) as stream:
        for recorded in stream:
            batch = _ir_reports(recorded)
            if batch is None:
                return
            yield from batch


def _ir_reports(recorded: RecordedMessage) -> list[tuple[float, bytes]] | None:
    """A report message's IR reports with their times (None: a message that does not parse)."""
    try:
        message = recorded.json()
        batch = [(float(t), bytes.fromhex(data)) for t, data in zip(message["t"], message["data"])]
    except (KeyError, TypeError, ValueError):
        return None
    return [(t, report) for t, report in batch if report and report[0] in IR_REPORTS]


def recorded_calibration(recording: Recording) -> StereoCalibration | None:
    """The calibration the recording tracked with last (its projection matrices), or None: a pass
    over the file's `/calibration` messages."""
    last = None
    for message in recording.topic(CALIBRATION):
        last = message
    if last is None:
        return None
    cameras = tuple(
        CalibratedCamera.from_dict({"P": P, "method": "recorded", "name": f"cam{c}"}) for c, P in enumerate(last["Ps"])
    )
    return StereoCalibration(cameras, str(last.get("frame_id", recording.frame_id)))


class ReplayStart:
    """When the replayed remotes' shared timeline started: every camera plays report time r at
    clock time `t0` + (r - `r0`), so the cameras stay as synchronised as they were recorded (the
    first to stream sets `t0`; one that starts later sends what is due at once, as a remote's
    buffer would). The timeline repeats every `period` s.

    `ReplayStart.of(recording)` finds `r0` and `period` in a first pass over the reports (and
    counts each camera's IR reports, `counts`, and where a damaged file ends, `end`)."""

    def __init__(self, firsts: list[float], lasts: list[float]) -> None:
        if not firsts:
            raise ValueError("no IR reports to replay")
        self.r0 = min(firsts)
        self.period = max(lasts) - self.r0 + 0.01
        self.t0: float | None = None
        self.counts: list[int] = []
        self.end: str | None = None

    @classmethod
    def of(cls, recording: Recording) -> ReplayStart:
        firsts: dict[int, float] = {}
        lasts: dict[int, float] = {}
        counts = [0] * recording.cameras
        with recording.messages([reports_topic(c) for c in range(recording.cameras)]) as stream:
            for recorded in stream:
                batch = _ir_reports(recorded)
                if batch is None:  # a damaged message: the intact part ends there, as for the remotes
                    break
                if batch:
                    c = int(recorded.topic.split("/")[2])
                    firsts.setdefault(c, batch[0][0])
                    lasts[c] = batch[-1][0]
                    counts[c] += len(batch)
            end = stream.end
        start = cls(list(firsts.values()), list(lasts.values()))
        start.counts, start.end = counts, end
        return start


class ReplayedRemote:
    """A `Transport` that plays one camera's recorded IR reports (see the module docstring), read
    from the file as they are sent: each lap is a new pass over it."""

    def __init__(self, recording: Recording, camera: int, clock: Clock, start: ReplayStart) -> None:
        self.recording = recording
        self.camera = camera
        self.clock = clock
        self.start = start
        self._replies: deque[bytes] = deque()
        self._open = False
        self._streaming = False
        self._reports: Generator[tuple[float, bytes], None, None] | None = None
        self._due: tuple[float, bytes] | None = None  # the next report to send
        self._lap = -1

    def open(self) -> None:
        self._open = True

    def close(self) -> None:
        self._open = False
        self._streaming = False
        self._end_lap()

    def write(self, data: bytes) -> int:
        if not self._open:
            raise OSError("the replayed remote is closed")
        rid = data[0]
        if rid == OUT_STATUS_REQUEST:
            self._replies.append(encode_status(battery=0xC0))
        else:
            self._replies.append(encode_ack(rid))
        if rid == OUT_REPORT_MODE:
            self._streaming = True
            if self.start.t0 is None:
                self.start.t0 = self.clock.now()
        return len(data)

    def read(self, max_size: int, timeout_ms: int) -> bytes:
        if not self._open:
            raise OSError("the replayed remote is closed")
        if self._replies:
            return self._replies.popleft()
        t0 = self.start.t0
        if not self._streaming or t0 is None:
            return b""
        t, report = self._due = self._due or self._next_report()
        if t - self.start.r0 + self._lap * self.start.period <= self.clock.now() - t0:
            self._due = None
            return report
        return b""

    def _next_report(self) -> tuple[float, bytes]:
        """The next recorded IR report, from the start of the file again (the next lap) when they
        run out. OSError when the file can no longer be read or holds none (a transport's failure)."""
        for _ in range(2):  # this lap's next report, or the next lap's first
            if self._reports is None:
                self._reports = recorded_ir_reports(self.recording, self.camera)
                self._lap += 1
            try:
                report = next(self._reports, None)
            except RecordingError as exc:
                self._end_lap()
                raise OSError(str(exc)) from None
            if report is not None:
                return report
            self._end_lap()
        raise OSError(f"{self.recording.path}: camera {self.camera} has no IR reports to replay")

    def _end_lap(self) -> None:
        reports, self._reports = self._reports, None
        if reports is not None:
            reports.close()
