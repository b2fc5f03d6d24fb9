"""The arms' dynamic parameters, the hand and the ball of the MuJoCo world, each with where it
comes from (docs/simulation.md, "The MuJoCo world", repeats the table with the sources).

An arm's dynamics are an `ArmDynamics`: the PA-10's from the published figures below (`PA10`);
any other arm's from its URDF's inertials and joint efforts (`from_urdf`: the Panda's
example-robot-data URDF carries Franka's published masses, centres of mass and inertias and the
87/12 N m torque limits; the UR5e's, written by robot/urdf/make_ur5e.py, UR's published masses and
centres of mass with solid-cylinder inertias and its 150/28 N m torques), with the rotor inertia and
the friction estimated by the rules stated at `ROTOR_ACCELERATION` and `VISCOUS_SHARE`.

The PA-10:

Published (the PA-10 dynamic model distributed with the Siconos simulation software, INRIA:
its header `PA10` model, "link masses (kg)", "center of mass (m)", "motor constants (link-referenced
in kg-m^2)"; the same numbers appear in the PA-10 modelling literature of the mid 2000s, e.g.
Kennedy and Desai, "Modeling and control of the Mitsubishi PA-10 robot arm harmonic drive system",
IEEE/ASME Trans. Mechatronics 10(3), 2005, which we could not read here to check them against):

* link masses of links 2-7: 8.41, 3.51, 4.31, 3.45, 1.46, 0.24 kg;
* centre-of-mass offsets of links 2-7 along their link axes: 0.06325, 0.08944, 0.04609, 0.1647,
  -0.03, -0.029 m, read in our URDF's frames as below (`COM_Z_M`; the source's DH frames put the
  offsets of links 3 and 5 at the far joint, pointing back, and those of 6 and 7 behind the wrist
  and the flange);
* rotor inertias reflected through the gears ("link-referenced"): 0.75, 0.75, 0.2125, 0.2125,
  0.00575, 0.00575, 0.00575 kg m^2: MuJoCo's joint `armature`.

Estimates (no per-link figure found; said so in the docs, never presented as published):

* inertia tensors about each link's centre of mass: solid cylinders of the published mass with
  the radius and length the URDF draws (the source gives only 24 lumped inertia constants of its
  own formulation, which do not separate into per-link tensors);
* link 1's mass, 10 kg: it turns only about the vertical joint 1, which a throw holds still;
* joint friction: viscous 3 % and Coulomb 3 % of each joint's torque limit at its velocity limit,
  typical of harmonic-drive joints; the source's own viscous constants are placeholders (1.0);
* torque limits 232, 232, 100, 100, 14.5, 14.5, 14.5 N m: those of the project's URDF
  (docs/robot.md); the servo saturates there;
* the hand: a 0.4 kg palm and two 0.05 kg fingers with rubber pads (friction 1.0), closing with
  20 N (settings), the paper does not describe its gripper.

Units SI; link names are the URDF's (`link1` turns with S1, ..., `link7` with W2).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

#: Link masses (kg): links 2-7 published, link 1 estimated (module docstring).
LINK_MASS_KG = MappingProxyType(
    {"link1": 10.0, "link2": 8.41, "link3": 3.51, "link4": 4.31, "link5": 3.45, "link6": 1.46, "link7": 0.24}
)

#: Centre of mass along each link's z axis (m, in the URDF link frame, which is parallel to base at
#: q = 0): link 1 from the URDF's cylinders; links 2-7 from the published offsets: link 2 0.06325 up
#: the upper arm; link 3 0.08944 back from the elbow (0.45 - 0.08944); link 4 0.04609 beyond the
#: elbow; link 5 0.1647 back from the wrist (0.48 - 0.1647); link 6 0.03 behind the wrist; link 7
#: 0.029 behind the flange (0.07 - 0.029).
COM_Z_M = MappingProxyType(
    {
        "link1": 0.2709,
        "link2": 0.06325,
        "link3": 0.45 - 0.08944,
        "link4": 0.04609,
        "link5": 0.48 - 0.1647,
        "link6": -0.03,
        "link7": 0.07 - 0.029,
    }
)

#: The cylinder (radius, length) (m) of each link for the inertia estimate: the URDF's main cylinder.
LINK_CYLINDER_M = MappingProxyType(
    {
        "link1": (0.085, 0.197),
        "link2": (0.075, 0.10),
        "link3": (0.07, 0.37),
        "link4": (0.065, 0.10),
        "link5": (0.055, 0.38),
        "link6": (0.045, 0.04),
        "link7": (0.04, 0.03),
    }
)

#: Rotor inertia reflected to each joint (kg m^2), published: MuJoCo's `armature`.
ROTOR_INERTIA = (0.75, 0.75, 0.2125, 0.2125, 0.00575, 0.00575, 0.00575)

#: Torque limits (N m), the project's URDF efforts: where the servo saturates.
TORQUE_LIMIT_NM = (232.0, 232.0, 100.0, 100.0, 14.5, 14.5, 14.5)

#: Velocity limits (rad/s) of the PA-10 (manufacturer; docs/robot.md): the friction estimates use them.
VELOCITY_LIMIT = (1.0, 1.0, 2.0, 2.0, 2 * math.pi, 2 * math.pi, 2 * math.pi)

#: Friction estimates as a share of the torque limit (module docstring).
VISCOUS_SHARE = 0.03  # viscous torque at the velocity limit / torque limit
COULOMB_SHARE = 0.03  # Coulomb torque / torque limit


#: Rotor inertia reflected to the joint of an arm whose maker publishes none (the Panda, the UR5e):
#: J_rotor = tau_max / ROTOR_ACCELERATION, the inertia the joint's torque limit alone would turn at
#: 1000 rad/s^2 (an estimate: Panda 0.087 / 0.012 kg m^2, UR5e 0.15 / 0.028 kg m^2, the order of a
#: harmonic drive's rotor, ~1e-5 kg m^2, through a gear of ratio ~100; the PA-10's published figures
#: are 0.0032-0.0004 kg m^2 per N m, this rule 0.001).
ROTOR_ACCELERATION = 1000.0  # rad/s^2


@dataclass(frozen=True)
class ArmDynamics:
    """What the MuJoCo world puts on each joint of an arm, and on each link when the URDF's
    inertials are replaced (`links`: the URDF link each joint turns, in joint order). `mass_kg`,
    `com_z_m`, `cylinder_m`: per link, or None to keep the URDF's inertial as it is. `source`: where
    the figures come from (docs/simulation.md)."""

    links: tuple[str, ...]
    torque_limit_nm: tuple[float, ...]
    velocity_limit: tuple[float, ...]
    rotor_inertia: tuple[float, ...]
    source: str
    mass_kg: Mapping[str, float] | None = None
    com_z_m: Mapping[str, float] | None = None
    cylinder_m: Mapping[str, tuple[float, float]] | None = None

    def viscous_damping(self) -> tuple[float, ...]:
        """Joint viscous friction b (N m s/rad): b v_max = VISCOUS_SHARE tau_max."""
        return tuple(VISCOUS_SHARE * t / v for t, v in zip(self.torque_limit_nm, self.velocity_limit))

    def coulomb_friction(self) -> tuple[float, ...]:
        """Joint Coulomb friction (N m): MuJoCo's `frictionloss`."""
        return tuple(COULOMB_SHARE * t for t in self.torque_limit_nm)


#: The PA-10 (published masses, centres of mass and rotor inertias; estimates stated above).
PA10 = ArmDynamics(
    links=("link1", "link2", "link3", "link4", "link5", "link6", "link7"),
    torque_limit_nm=TORQUE_LIMIT_NM,
    velocity_limit=VELOCITY_LIMIT,
    rotor_inertia=ROTOR_INERTIA,
    source="the PA-10 model of the Siconos software (INRIA): masses, centres of mass, rotor inertias",
    mass_kg=LINK_MASS_KG,
    com_z_m=COM_Z_M,
    cylinder_m=LINK_CYLINDER_M,
)


def from_urdf(
    links: Sequence[str], torque_limit_nm: Sequence[float], velocity_limit: Sequence[float], source: str
) -> ArmDynamics:
    """An arm whose URDF carries its dynamics: the URDF's inertials kept, its efforts as the torque
    limits, the rotor inertia by the `ROTOR_ACCELERATION` rule, the friction by the shares."""
    torques = tuple(float(t) for t in torque_limit_nm)
    return ArmDynamics(
        links=tuple(links),
        torque_limit_nm=torques,
        velocity_limit=tuple(float(v) for v in velocity_limit),
        rotor_inertia=tuple(t / ROTOR_ACCELERATION for t in torques),
        source=source,
    )


def cylinder_inertia(mass: float, radius: float, length: float) -> tuple[float, float, float]:
    """Principal inertia (Ixx, Iyy, Izz) (kg m^2) of a solid cylinder along z about its centre:
    I_xx = I_yy = m (3 r^2 + h^2) / 12, I_zz = m r^2 / 2."""
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    return (transverse, transverse, 0.5 * mass * radius**2)


# -- the hand (estimates) -----------------------------------------------------------------------

PALM_MASS_KG = 0.4
FINGER_MASS_KG = 0.05
PAD_FRICTION = 1.0  # rubber on felt
#: Pad half-sizes (m): 20 mm along the hand's x, 5 mm thick (along y, the closing direction), 20 mm along z.
PAD_HALF_M = (0.02, 0.005, 0.02)
#: How far each pad travels from touching the ball to fully open (m).
FINGER_STROKE_M = 0.03

# -- the ball ------------------------------------------------------------------------------------

#: A tennis ball is a hollow shell: I = 2/3 m r^2.
SHELL_INERTIA_FACTOR = 2.0 / 3.0
#: Coefficient of restitution of the bounce (a tennis ball on a hard floor drops to about 55 % of
#: its height: e = sqrt(0.55) ~ 0.75); MuJoCo's contact damping ratio is set to give it.
BALL_RESTITUTION = 0.75
#: Kinematic viscosity of air (m^2/s), MuJoCo's `viscosity` (its docs' value for room air).
AIR_KINEMATIC_VISCOSITY = 1.48e-5
