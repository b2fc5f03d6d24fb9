"""Training the throw library in the world, as the paper's operator does on the real arm.

Each training throw starts from the home pose, as a user's throws do. For each training target
the operator finds a throw that lands there (in simulation: the
noise-free model solved by `throwing.solve_throw`, standing in for the operator's trial and error),
the arm plays it once, an IR marker is put where the ball landed and the stereo rig measures it:
that measured landing is the throw's label: its (x, z) in the throw's plane, and how far beside
the plane it came down (the library's sideways term learns that: `throwing.lateral`). Labels come from the same rig and calibration that
will measure future targets, which is why calibration error is largely compensated by the
learning (the paper's claim; see `wiithrow.app.studies.compensation`).

Who puts the marker down: a simulated world does itself (its operator, `execute_throw`); on the
hardware path nobody but the operator knows where the ball came down, and `measure_landing(target)`
asks them and measures it (`wiithrow bench throwing --settings`: the drivers' simulated operator).
Before each throw the world is told the surface it comes down on (`RigWorld.set_surface`: the
training target's height). A late release (`ThrowExecution.release_late_s`) labels nothing: the
training stops, saying so.

This is the training in one call that the benchmarks, the studies and the examples run; `wiithrow
train` and the dashboard run the operator's procedure step by step, saved after every throw, with
retries and skips (`wiithrow.app.throws.training_run`, the session's training steps).

`training_grid(area, throws)`: `throws` targets on an NX x NZ grid over the area (25: the paper's
5 x 5).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wiithrow.app.errors import AppError
from wiithrow.app.rig.waiting import pump
from wiithrow.app.throws.execution import ball_of, execute_throw, planning_start, return_home
from wiithrow.app.worlds import RigWorld
from wiithrow.throwing import (
    Area,
    ThrowLibrary,
    ThrowParameters,
    plan_throw,
    require_valid,
    simulate_training,
    training_targets,
)

#: Asks the operator to mark the landing of the throw at `target` (x, z) and returns the rig's
#: measurement of the marker (3,) in link1.
MeasureLanding = Callable[[np.ndarray], np.ndarray]


def training_grid(area: Area, throws: int) -> np.ndarray:
    """`throws` training targets (N, 2): an NX x NZ grid over `area` with NZ the largest divisor
    of `throws` up to its square root, at least 2 (25: 5 x 5, 10: 5 x 2, 16: 4 x 4). ValueError
    for a count with no such grid (a prime, or under 4)."""
    nz = max((d for d in range(2, int(np.sqrt(throws)) + 1) if throws % d == 0), default=0)
    if nz == 0:
        raise ValueError(
            f"{throws} training throws make no grid of distances and heights (at least 2 x 2): "
            "give a count like 10 (5 x 2), 12, 16 or 25 (the paper's 5 x 5)"
        )
    return training_targets(area, throws // nz, nz)


def world_execute_and_measure(
    world: RigWorld,
    *,
    floor_margin: float = 0.05,
    on_throw: Callable[[np.ndarray, np.ndarray], None] | None = None,
    measure_landing: MeasureLanding | None = None,
):
    """`execute_and_measure(params, target)` for `throwing.simulate_training`: plan the throw from
    the arm's pose, validate it, play it in the world and return the rig's measured landing in the
    throw's plane, (x, y, z) with y how far beside the plane it came down (the world's own
    measurement, else `measure_landing`'s: the operator's, on hardware); `on_throw(target, (x, z))`."""
    ball = ball_of(world)

    def execute_and_measure(params: ThrowParameters, target) -> np.ndarray:
        # every training throw starts from the home pose at rest, as every throw of `wiithrow
        # throw` and the demo's first do: in a world whose physics the planner does not know, a
        # throw depends on where it starts (the approach, the ball settling in the grip), and the
        # labels must describe the throws the library will serve (MuJoCo, demo target: 9-17 mm
        # from home with a library trained throw after throw, 3-5 mm with one trained from home)
        return_home(world)
        pump(world.clock, world.rig, 0.05, step_s=0.01)
        q = planning_start(world)
        plan = plan_throw(
            world.arm_model,
            params,
            float(target[1]),
            q1=float(q[0]),
            ball=ball,
            q_start=q,
            target=np.asarray(target, float),
        )
        # the ball comes down on the training target's surface (the operator's marker), whatever else is lit
        execution = execute_throw(
            world, require_valid(plan, world.arm_model, floor_margin=floor_margin), surface_height=float(target[1])
        )
        if execution.late_release is not None:  # its landing is not the planned throw's: it labels nothing
            raise AppError(
                f"the training throw at x {target[0]:.3f} z {target[1]:.3f} m: {execution.late_release}; train again"
            )
        measured = execution.measured_plane  # (x, across, z) in the throw's plane
        if not np.isfinite(measured).all() and measure_landing is not None:
            # the operator marks it with joint 1 where the throw left it: link1 is the throw's plane
            measured = np.asarray(measure_landing(np.asarray(target, float)), dtype=float)
        if on_throw is not None:
            on_throw(np.asarray(target, float), measured[[0, 2]])
        return measured

    return execute_and_measure


def train_in_world(
    world: RigWorld,
    rng: np.random.Generator,
    *,
    targets=None,
    placement_jitter: float = 0.01,
    on_throw: Callable[[np.ndarray, np.ndarray], None] | None = None,
    measure_landing: MeasureLanding | None = None,
    meta: dict | None = None,
) -> ThrowLibrary:
    """The 25-throw library (5 x 5 grid over the arm's training area, its spec's, unless
    `targets`), labelled by the rig's measurements; the throws move the arm's pitch joints
    (`throwing.shape_for`). The world must be calibrated. `measure_landing`: who marks a landing
    the world does not measure itself (hardware: the operator)."""
    if not world.rig.calibrated:
        raise ValueError("training measures landings with the rig: calibrate it first")
    return_home(world)
    rng.integers(2**63)  # the draw that seeded the executions' (unused) generator: the same libraries as before
    execute = world_execute_and_measure(world, on_throw=on_throw, measure_landing=measure_landing)
    where = "simulated world" if world.simulated else "hardware path: the drivers the settings name"
    info = {
        "execution": f"wiithrow.app.throws.training ({where}, rig-measured labels)",
        "arm": world.arm_model.name,
        "noise": world.settings.noise.__dict__,
        **(meta or {}),
    }
    return simulate_training(
        world.arm_model, targets, execute, rng, ball=ball_of(world), placement_jitter=placement_jitter, meta=info
    )
