"""The operator's session: what an operator does (calibrate, track, preview, throw, stop) on a
world, one operation at a time, and what its views are shown.

Modules: `session` (the `Session`), `records` (previews, throw records, snapshots), `simulated`
(the one factory of a session on the simulated world).
"""

from wiithrow.app.session.records import SessionSnapshot, ThrowPreview, ThrowRecord
from wiithrow.app.session.session import DEFAULT_MARGIN_M, Busy, Session
from wiithrow.app.session.simulated import demo_target_base, simulated_session

__all__ = [
    "DEFAULT_MARGIN_M",
    "Busy",
    "Session",
    "SessionSnapshot",
    "ThrowPreview",
    "ThrowRecord",
    "demo_target_base",
    "simulated_session",
]
