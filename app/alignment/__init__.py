"""Joint-1 alignment: turning the arm until the target lies in the throw plane.

Modules: `aligner` (the loop, its phases and its result), `commander` (streaming joint 1 at a
wanted velocity), `target` (the target's position and azimuth from tracked frames), `search`
(where joint 1 looks for a target out of view).
"""

from wiithrow.app.alignment.aligner import AlignmentOptions, AlignmentResult, Joint1Aligner, align_joint1
from wiithrow.app.alignment.commander import Joint1Commander
from wiithrow.app.alignment.search import sweep_waypoints

__all__ = ["AlignmentOptions", "AlignmentResult", "Joint1Aligner", "Joint1Commander", "align_joint1", "sweep_waypoints"]
