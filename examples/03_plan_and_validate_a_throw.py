"""Plan a throw for the PA-10 and check it against the arm's limits, without an arm.

The throw planner generalises the 25 trained throws of the shipped library (a Gaussian process
from the landing to the release state), makes a Ruckig trajectory through them and passes it to
the independent validator (positions, velocities, accelerations, jerks, the floor): only a
validated throw can be executed. A target outside what was trained is refused with a clear error.

    python examples/03_plan_and_validate_a_throw.py
"""

import numpy as np

from wiithrow.app.throws.library_file import load_library
from wiithrow.robot import load_arm
from wiithrow.throwing import ThrowingError, ThrowPlanner, validate

arm = load_arm("pa10")
planner = ThrowPlanner(arm, load_library())

throw = planner.plan((1.3, 0.2), q1=0.3)  # 1.3 m from joint 1's axis, 0.2 m high; joint 1 at 0.3 rad
release = throw.release
print(
    f"release after {throw.release_time:.3f} s at {np.round(release.position, 3)} m (base), "
    f"{np.linalg.norm(release.velocity):.2f} m/s"
)
print(f"predicted landing (x, z) in the throw plane: {np.round(throw.predicted.xz, 4)} m")

report = validate(throw.trajectory, arm)  # what the planner already checked, done again here
print(
    f"validator: {'ok' if report.ok else report.summary()}, {len(throw.trajectory.times)} samples, "
    f"lowest point {report.min_clearance:.2f} m above the floor"
)
peak = np.abs(throw.trajectory.velocities).max(axis=0) / arm.velocity_limit
print("peak joint speed / limit: " + ", ".join(f"{n} {r:.0%}" for n, r in zip(arm.joint_names, peak)))

try:
    planner.plan((3.0, 0.2))  # beyond the trained area (x 1.0-1.6 m)
except ThrowingError as exc:
    print(f"refused: {exc}")
