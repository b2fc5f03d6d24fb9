"""The session's state read one field at a time: `SnapshotFields`, the read-only properties
(`busy`, `operation`, `preview`, `history`, ...) that `Session` offers over its immutable
`SessionSnapshot`, for the readers that want one field. Each reads the current snapshot; none
writes (the session replaces its snapshot whole: `wiithrow.app.session.session`).
"""

from __future__ import annotations

from wiithrow.app.alignment import AlignmentResult
from wiithrow.app.calibration.robot import RobotCalibration
from wiithrow.app.calibration.wand import WandRun
from wiithrow.app.calibration.wand_capture import CaptureProgress
from wiithrow.app.session.operations import Operation
from wiithrow.app.session.records import SessionSnapshot, ThrowPreview, ThrowRecord


class SnapshotFields:
    """One field of `snapshot()` per property (a subclass provides `snapshot`)."""

    def snapshot(self) -> SessionSnapshot:
        raise NotImplementedError

    @property
    def busy(self) -> bool:
        return self.snapshot().busy

    @property
    def operation(self) -> Operation | None:
        return self.snapshot().operation

    @property
    def progress(self) -> tuple[str, float]:
        return self.snapshot().progress

    @property
    def last_message(self) -> str:
        return self.snapshot().message

    @property
    def calibration_result(self) -> RobotCalibration | None:
        return self.snapshot().calibration

    @property
    def wand_result(self) -> WandRun | None:
        return self.snapshot().wand

    @property
    def wand_progress(self) -> CaptureProgress | None:
        return self.snapshot().wand_progress

    @property
    def alignment(self) -> AlignmentResult | None:
        return self.snapshot().alignment

    @property
    def preview(self) -> ThrowPreview | None:
        return self.snapshot().preview

    @property
    def history(self) -> tuple[ThrowRecord, ...]:
        return self.snapshot().history

    @property
    def learning(self) -> bool:
        return self.snapshot().learning
