"""Another arm (the Franka Panda, or the UR5e) trains and throws in the MuJoCo world built from its
URDF: the paper's procedure, each training throw labelled by the rig's measurement of where the
simulated operator put the landing marker, then throws to seeded targets inside the arm's trained
area, each from home at rest.

    python examples/06_another_arm_in_mujoco.py                                  # Panda, 3 x 3, 4 throws (~40 s)
    python examples/06_another_arm_in_mujoco.py --arm ur5e --grid 5 --throws 10  # the docs' figures (~2 min)

The rig is calibrated with the true cameras, to be quick (the robot-driven calibration is
`simulated_session(..., calibration="robot")`). Figures: docs/simulation.md, "The Panda, the UR5e
and a lab's arm".
"""

import argparse

import numpy as np

from wiithrow.app.rig.waiting import pump
from wiithrow.app.settings import Settings
from wiithrow.app.throws.execution import execute_throw, planning_start, return_home
from wiithrow.app.throws.training import train_in_world
from wiithrow.app.worlds.mujoco.world import MujocoWorld
from wiithrow.throwing import ThrowPlanner, training_targets
from wiithrow.throwing.arm_throwing import training_area

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--arm", default="panda", help="a shipped arm with a throwing section: panda, ur5e, pa10")
parser.add_argument("--grid", type=int, default=3, help="the training grid is GRID x GRID over the area (paper: 5)")
parser.add_argument("--throws", type=int, default=4, help="throws to seeded targets after the training")
args = parser.parse_args()

world = MujocoWorld(Settings(arm=args.arm), seed=3)
world.set_calibration(world.true_calibration())
world.connect()
pump(world.clock, world.rig, 0.2, step_s=0.001)
arm = world.arm_model
area = training_area(arm)
library = train_in_world(world, np.random.default_rng(0), targets=training_targets(area, nx=args.grid, nz=args.grid))
print(f"{arm.name}: trained {len(library)} throws over x {area.x[0]}-{area.x[1]} m, z {area.z[0]}-{area.z[1]} m")

planner = ThrowPlanner(arm, library)
rng = np.random.default_rng(11)
true_errors, measured_errors = [], []
for _ in range(args.throws):
    target = np.array([rng.uniform(area.x[0] + 0.05, area.x[1] - 0.05), rng.uniform(area.z[0], area.z[1] - 0.05)])
    return_home(world)  # every throw starts from home at rest, as the labelled ones did
    pump(world.clock, world.rig, 0.05, step_s=0.001)
    q = planning_start(world)
    done = execute_throw(world, planner.plan(target, q1=float(q[0]), q_start=q), surface_height=float(target[1]))
    true_errors.append(float(np.hypot(done.landing_link1[0] - target[0], done.landing_link1[1])))
    measured_errors.append(float(np.hypot(done.measured_link1[0] - target[0], done.measured_link1[1])))
    print(
        f"  target x {target[0]:.3f} z {target[1]:.3f} m: {1e3 * true_errors[-1]:.1f} mm off "
        f"(rig-measured {1e3 * measured_errors[-1]:.1f} mm)"
    )
print(
    f"median landing error {1e3 * np.median(true_errors):.1f} mm (largest {1e3 * max(true_errors):.1f} mm), "
    f"rig-measured {1e3 * np.median(measured_errors):.1f} mm (largest {1e3 * max(measured_errors):.1f} mm)"
)
