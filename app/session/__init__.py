"""The operator's session: what an operator does (calibrate, track, preview, throw, stop) on a
world, one operation at a time, and what its views are shown.

Modules: `session` (the `Session`), `operations` (the `Operation` and `Event` enums), `refusals`
(each operation's precondition, once: `refusal`), `records` (previews, throw records, the state's
snapshot), `status` (what the state says in words: the one calibration state, a throw's
outcome), `rig_loop` (the loop that reads the rig while no operation runs), `simulated` (the one
factory of a session on the simulated world).
"""

from wiithrow.app.session.operations import Event, Operation, busy_reason
from wiithrow.app.session.records import TARGET_MOVED_M, SessionSnapshot, ThrowPreview, ThrowRecord
from wiithrow.app.session.refusals import NO_ARM, Busy, Refusal, refusal
from wiithrow.app.session.session import DEFAULT_MARGIN_M, PLACE_MARKER, Session
from wiithrow.app.session.simulated import demo_target_base, simulated_session
from wiithrow.app.session.status import calibration_state, throw_outcome

__all__ = [
    "DEFAULT_MARGIN_M",
    "NO_ARM",
    "PLACE_MARKER",
    "TARGET_MOVED_M",
    "Busy",
    "Event",
    "Operation",
    "Refusal",
    "Session",
    "SessionSnapshot",
    "ThrowPreview",
    "ThrowRecord",
    "busy_reason",
    "calibration_state",
    "demo_target_base",
    "refusal",
    "simulated_session",
    "throw_outcome",
]
