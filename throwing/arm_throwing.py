"""How a given arm throws: its `ThrowShape`, its operator's preferred release pose and its training
area, from the throwing section of the arm's spec (`robot.spec.ThrowingSpec`, `ArmModel.spec`).

The throw moves the spec's pitch joints (PA-10 S2, E1, W1; Panda joints 2, 4, 6; UR5e
shoulder_lift, elbow, wrist_1), whose axes are all parallel to link1's y axis, and holds every
other joint but joint 1. Every point of the hand then moves in a plane y = const of link1; the
throw plane is y = 0, so the ball must lie in it. Where the arm's wrist is offset from the
shoulder's plane (the UR's d4 = 0.133 m), the spec names a held `plane_joint` (the UR's wrist 2)
whose angle is solved here, by Newton's method from the stated angle, so that

    y_ball(theta) = [R_1^T (p_ball(q(theta)) - o_1)]_y = 0        (m, link1)

(for the UR5e: -pi/2 - asin(d4 / (d6 + ball offset)) = -2.134 rad with the ball 0.15 m beyond the
flange, the tool tilted 32.3 degrees out of the throw's plane). `shape_for` then checks
that the ball stays in the plane over the throwing joints' range (a spec whose joints are not
pitch joints is refused). Results are cached per arm.

An arm loaded without a spec (built by hand) or a spec without a throwing section has no shape:
ThrowingError. Areas are (x, z) ranges of the throw plane, m.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiithrow.robot import ArmModel
from wiithrow.robot.spec import ThrowingSpec
from wiithrow.throwing.errors import ThrowingError
from wiithrow.throwing.representation import ThrowShape

#: How far (m) the ball may be from the throw plane y = 0 at any pose of the throwing joints.
PLANE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Area:
    """An axis-aligned area of the throw plane (link1): x (distance) and z (height) ranges (m)."""

    x: tuple[float, float]
    z: tuple[float, float]

    def __str__(self) -> str:
        return f"x {self.x[0]:.2f}-{self.x[1]:.2f} m, z {self.z[0]:.2f}-{self.z[1]:.2f} m (link1)"


_SHAPES: weakref.WeakKeyDictionary[ArmModel, ThrowShape] = weakref.WeakKeyDictionary()


def throwing_spec(arm: ArmModel) -> ThrowingSpec:
    """The throwing section of the arm's spec; ThrowingError if it has none."""
    spec = arm.spec
    if spec is None or spec.throwing is None:
        raise ThrowingError(
            f"arm '{arm.name}' has no throwing section in its spec (its pitch joints, held joints, training area): "
            "give one (docs/robot.md, 'Adding an arm') or pass a ThrowShape"
        )
    return spec.throwing


def training_area(arm: ArmModel) -> Area:
    """The arm's training area in the throw plane (m), as its spec states it."""
    t = throwing_spec(arm)
    return Area(t.area_x, t.area_z)


def nominal_release(arm: ArmModel) -> tuple[float, ...]:
    """The release pose (rad) of the throwing joints the simulated operator prefers."""
    return throwing_spec(arm).nominal_release


def directions(arm: ArmModel) -> NDArray[np.float64]:
    """(n,) the sign (+1, -1) of each throwing joint's velocity in a throw."""
    return np.asarray(throwing_spec(arm).directions, dtype=float)


def shape_for(arm: ArmModel) -> ThrowShape:
    """The arm's throw shape (module docstring); ThrowingError if its spec has no throwing section,
    names joints it lacks, or its throwing joints do not keep the ball in the throw plane."""
    shape = _SHAPES.get(arm)
    if shape is None:
        shape = _SHAPES[arm] = _build(arm, throwing_spec(arm))
    return shape


def _ball_y(arm: ArmModel, shape: ThrowShape, q_moving: NDArray[np.float64]) -> float:
    q = shape.full_q(arm, q_moving, 0.0)
    return float(arm.to_frame(arm.frame_position(q, "ball"), q, "link1")[1])


def _build(arm: ArmModel, t: ThrowingSpec) -> ThrowShape:
    held = list(t.held)
    shape = ThrowShape(t.joints, tuple(held), acceleration_time=t.acceleration_time)
    shape.joint_layout(arm)  # every joint accounted for, or a ThrowingError naming them
    q_nom = np.asarray(t.nominal_release, dtype=float)
    if t.plane_joint:
        k = [n for n, _ in held].index(t.plane_joint)
        theta = held[k][1]
        for _ in range(50):
            cur = ThrowShape(t.joints, tuple(held[:k] + [(t.plane_joint, theta)] + held[k + 1 :]))
            y = _ball_y(arm, cur, q_nom)
            if abs(y) < 1e-12:
                break
            h = 1e-7
            up = ThrowShape(t.joints, tuple(held[:k] + [(t.plane_joint, theta + h)] + held[k + 1 :]))
            slope = (_ball_y(arm, up, q_nom) - y) / h
            if abs(slope) < 1e-9:
                break
            theta -= y / slope
        held[k] = (t.plane_joint, float(theta))
        shape = ThrowShape(t.joints, tuple(held), acceleration_time=t.acceleration_time)
    mov, _, _ = shape.joint_layout(arm)
    rng = np.random.default_rng(0)  # fixed probe poses inside the limits
    probes = [q_nom] + [rng.uniform(arm.lower[mov], arm.upper[mov]) for _ in range(4)]
    for q in probes:
        y = _ball_y(arm, shape, np.asarray(q, dtype=float))
        if not abs(y) <= PLANE_TOLERANCE:
            raise ThrowingError(
                f"arm '{arm.name}': with its throwing joints {list(t.joints)} at {np.round(q, 3).tolist()} rad the "
                f"ball is {y:+.4f} m off the throw plane (y = 0 of link1): the throwing joints must be pitch joints "
                "(axes along link1's y) and the held angles must put the ball in the plane (or name a plane_joint)"
            )
    return shape
