"""The whole throwing task in the simulated world, as the operator does it from the dashboard.

A `Session` on the simulated world (arm, two Wiimotes speaking HID bytes, ball with drag):
calibrate the rig (here with the true cameras, to be quick; `calibration="robot"` runs the
paper's 30-pose procedure), put the IR target down, turn joint 1 until the target is in the throw
plane, preview the validated throw, throw it, and read where the rig saw the ball land: its error
in 3D, the total on the floor and its parts along and across the throw (mm).

    python examples/05_throw_in_the_simulated_world.py
"""

import numpy as np

from wiithrow.app.session import simulated_session

session = simulated_session(seed=0, calibration="true")
session.set_target([1.2, 0.25, 0.1])  # base frame, m: 1.2 m ahead, a little to the left, 10 cm up

alignment = session.align()  # joint 1 turns until the target lies in the plane y = 0 of link1
print(
    f"alignment {alignment.status} in {alignment.duration_s:.1f} s: joint 1 at {np.degrees(alignment.q1):.1f} deg, "
    f"target (x, z) = {np.round(alignment.throw_xz, 3)} m"
)

preview = session.plan_preview()  # planned from the arm's pose now, validated
print(f"preview {preview.id}: {preview.duration_s:.2f} s, peak speed {preview.speed_ratio.max():.0%} of a limit")

record = session.throw(preview.id)  # executes that preview, once
truth = record.true_error  # the simulation knows where the ball and the target really are
print(
    f"landed {record.error.words('mm')} from the target as the rig measured it "
    f"(simulation truth: {truth.words('mm') if truth is not None else 'unknown'})"
)
