"""`ReplayedRemote`: a recording's remote as a `Transport`, for the dashboard to watch a replay.

It answers a `WiimoteDriver` as a remote would, from a recording: it acknowledges every output
report it is sent (0x22) and answers a status request, and once the driver sets the reporting
mode it sends that camera's recorded IR reports at their recorded pace on the driver's clock, from
the start again when they run out (at the recorded pace only: the driver dates the reports of a
batch 10 ms apart, as a remote sends them). The driver, synchroniser and tracker
then run live on them (`wiithrow replay --dashboard`): the markers move as recorded, but the
reports are read in batches of this run, not the recorded ones, so the numbers are not the
recorded ones to the last digit (`Replay` gives those).
"""

from __future__ import annotations

from collections import deque

from wiithrow.app.recording.channels import CALIBRATION, reports_topic
from wiithrow.app.recording.replay import Recording
from wiithrow.clock import Clock
from wiithrow.vision import StereoCalibration
from wiithrow.vision.dlt import CalibratedCamera
from wiithrow.vision.wiimote.input_reports import encode_ack, encode_status
from wiithrow.vision.wiimote.protocol import OUT_REPORT_MODE, OUT_STATUS_REQUEST

IR_REPORTS = frozenset({0x33, 0x36, 0x37, 0x3E, 0x3F})


def recorded_ir_reports(recording: Recording, camera: int) -> list[tuple[float, bytes]]:
    """Camera `camera`'s recorded IR reports with their receive times, in order."""
    out = []
    for message in recording.topic(reports_topic(camera)):
        for t, data in zip(message["t"], message["data"]):
            report = bytes.fromhex(data)
            if report and report[0] in IR_REPORTS:
                out.append((float(t), report))
    return out


def recorded_calibration(recording: Recording) -> StereoCalibration | None:
    """The calibration the recording tracked with last (its projection matrices), or None."""
    calibrations = recording.topic(CALIBRATION)
    if not calibrations:
        return None
    last = calibrations[-1]
    cameras = tuple(
        CalibratedCamera.from_dict({"P": P, "method": "recorded", "name": f"cam{c}"}) for c, P in enumerate(last["Ps"])
    )
    return StereoCalibration(cameras, str(last.get("frame_id", recording.frame_id)))


class ReplayStart:
    """When the replayed remotes' shared timeline started: every camera plays report time r at
    clock time `t0` + (r - `r0`), so the cameras stay as synchronised as they were recorded (the
    first to stream sets `t0`; one that starts later sends what is due at once, as a remote's
    buffer would). The timeline repeats every `period` s."""

    def __init__(self, reports: list[list[tuple[float, bytes]]]) -> None:
        firsts = [r[0][0] for r in reports if r]
        lasts = [r[-1][0] for r in reports if r]
        if not firsts:
            raise ValueError("no IR reports to replay")
        self.r0 = min(firsts)
        self.period = max(lasts) - self.r0 + 0.01
        self.t0: float | None = None


class ReplayedRemote:
    """A `Transport` that plays one camera's recorded IR reports (see the module docstring)."""

    def __init__(self, reports: list[tuple[float, bytes]], clock: Clock, start: ReplayStart) -> None:
        if not reports:
            raise ValueError("no IR reports to replay")
        self.reports = reports
        self.clock = clock
        self.start = start
        self._replies: deque[bytes] = deque()
        self._open = False
        self._streaming = False
        self._i = 0
        self._lap = 0

    def open(self) -> None:
        self._open = True

    def close(self) -> None:
        self._open = False
        self._streaming = False

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
        if self._i >= len(self.reports):  # the next lap of the shared timeline
            self._i, self._lap = 0, self._lap + 1
        t, report = self.reports[self._i]
        if t - self.start.r0 + self._lap * self.start.period <= self.clock.now() - t0:
            self._i += 1
            return report
        return b""
