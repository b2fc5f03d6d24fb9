"""Generator of robot/urdf/pa10.urdf: `python robot/urdf/make_pa10.py robot/urdf/pa10.urdf`.

The kinematics (joint origins, axes, limits) come from the DH table of docs/robot.md; masses and inertias are
plausible approximations computed from the simple cylinders that are also the visual and collision
geometry (solid cylinders, mass split by volume, parallel-axis theorem). Not imported by the package.
"""

import sys

import numpy as np
from numpy.typing import NDArray

# a cylinder: axis 'z' or 'y', radius (m), length (m), centre (x, y, z) in the link frame (m)
Shape = tuple[str, float, float, tuple[float, float, float]]

DEG = np.pi / 180
# name, parent, child, origin z in parent, axis, limit deg, vel rad/s, effort N m
JOINTS = [
    ("S1", "base",  "link1", 0.0,   "0 0 1", 177, 1.0,    232.0),
    ("S2", "link1", "link2", 0.317, "0 1 0",  91, 1.0,    232.0),
    ("S3", "link2", "link3", 0.0,   "0 0 1", 174, 2.0,    100.0),
    ("E1", "link3", "link4", 0.45,  "0 1 0", 137, 2.0,    100.0),
    ("E2", "link4", "link5", 0.0,   "0 0 1", 255, 6.2832,  14.5),
    ("W1", "link5", "link6", 0.48,  "0 1 0", 165, 6.2832,  14.5),
    ("W2", "link6", "link7", 0.0,   "0 0 1", 255, 6.2832,  14.5),
]
# per link: its mass (kg) and its cylinders (Shape)
LINKS: dict[str, tuple[float, list[Shape]]] = {
    "base":  (10.0, [("z", 0.10, 0.12, (0, 0, 0.06))]),
    "link1": (10.0, [("z", 0.085, 0.197, (0, 0, 0.2185)), ("y", 0.09, 0.20, (0, 0, 0.317))]),
    "link2": (4.5, [("z", 0.075, 0.10, (0, 0, 0.05))]),
    "link3": (6.5, [("z", 0.07, 0.37, (0, 0, 0.265)), ("y", 0.075, 0.16, (0, 0, 0.45))]),
    "link4": (3.0, [("z", 0.065, 0.10, (0, 0, 0.05))]),
    "link5": (3.0, [("z", 0.055, 0.38, (0, 0, 0.29)), ("y", 0.055, 0.12, (0, 0, 0.48))]),
    "link6": (1.8, [("z", 0.045, 0.04, (0, 0, 0.02))]),
    "link7": (0.8, [("z", 0.04, 0.03, (0, 0, 0.055))]),
}
COLORS = {"base": "grey", "link1": "white", "link2": "blue", "link3": "white", "link4": "blue",
          "link5": "white", "link6": "blue", "link7": "grey"}


def cyl_inertia(m: float, r: float, h: float, axis: str) -> NDArray[np.float64]:
    ia = 0.5 * m * r * r
    it = m * (3 * r * r + h * h) / 12
    d = {"z": np.diag([it, it, ia]), "y": np.diag([it, ia, it])}
    return d[axis]


def link_inertial(mass: float, shapes: list[Shape]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    vols = np.array([np.pi * r * r * h for _, r, h, _ in shapes])
    ms = mass * vols / vols.sum()
    cs = np.array([c for *_, c in shapes], float)
    com = (ms[:, None] * cs).sum(0) / mass
    inertia = np.zeros((3, 3))
    for m, (ax, r, h, c) in zip(ms, shapes):
        d = np.asarray(c, float) - com
        inertia += cyl_inertia(m, r, h, ax) + m * (d @ d * np.eye(3) - np.outer(d, d))
    return com, inertia


def f(x: float) -> str:
    return f"{x:.6g}"


def urdf_text() -> str:
    """The URDF of the PA-10, as text."""
    out: list[str] = []
    w = out.append
    w('<?xml version="1.0"?>')
    w("<!--")
    w("  Mitsubishi PA-10 (PA10-7C), written for wiithrow from the standard DH table of docs/robot.md:")
    w("    a = 0, alpha = (-pi/2, pi/2, -pi/2, pi/2, -pi/2, pi/2, 0), d = (0.317, 0, 0.45, 0, 0.48, 0, 0.07) m.")
    w("  Link frames are not DH frames: every link frame is parallel to `base` at q = 0 (z up, x forward),")
    w("  joint axes alternate z (S1, S3, E2, W2) and y (S2, E1, W1), so the kinematics equal the DH chain:")
    w("    R_flange = Rz(q1) Ry(q2) Rz(q3) Ry(q4) Rz(q5) Ry(q6) Rz(q7); flange at q = 0 is (0, 0, 1.317).")
    w("  `link1` is the base frame turned by q1 about z (origin at the base origin): the stereo rig is mounted")
    w("  on it. `flange` is DH frame 7 (z along the hand's approach direction).")
    w("  The `marker` and `ball` frames are not links of this file: their offsets beyond the flange are")
    w("  settings, added as Pinocchio frames by robot.load_arm.")
    w("  Limits: position (deg) +-177, +-91, +-174, +-137, +-255, +-165, +-255; velocity (rad/s) 1, 1, 2, 2,")
    w("  6.2832, 6.2832, 6.2832 (manufacturer). Efforts, masses and inertias are plausible approximations")
    w("  (total about 40 kg), made of the simple cylinders drawn below; no meshes.")
    w("-->")
    w('<robot name="pa10">')
    w('  <material name="white"><color rgba="0.92 0.92 0.90 1"/></material>')
    w('  <material name="blue"><color rgba="0.15 0.30 0.65 1"/></material>')
    w('  <material name="grey"><color rgba="0.45 0.45 0.48 1"/></material>')
    for name, (mass, shapes) in LINKS.items():
        com, I = link_inertial(mass, shapes)
        w(f'  <link name="{name}">')
        w("    <inertial>")
        w(f'      <origin xyz="{f(com[0])} {f(com[1])} {f(com[2])}" rpy="0 0 0"/>')
        w(f'      <mass value="{mass}"/>')
        w(f'      <inertia ixx="{f(I[0,0])}" ixy="{f(I[0,1])}" ixz="{f(I[0,2])}" iyy="{f(I[1,1])}" iyz="{f(I[1,2])}" izz="{f(I[2,2])}"/>')
        w("    </inertial>")
        for tag in ("visual", "collision"):
            for ax, r, h, c in shapes:
                rpy = "0 0 0" if ax == "z" else "1.5707963267948966 0 0"
                w(f"    <{tag}>")
                w(f'      <origin xyz="{f(c[0])} {f(c[1])} {f(c[2])}" rpy="{rpy}"/>')
                w(f'      <geometry><cylinder radius="{r}" length="{h}"/></geometry>')
                if tag == "visual":
                    w(f'      <material name="{COLORS[name]}"/>')
                w(f"    </{tag}>")
        w("  </link>")
    w('  <link name="flange">')
    w("    <visual>")
    w('      <origin xyz="0 0 -0.0025" rpy="0 0 0"/>')
    w('      <geometry><cylinder radius="0.03" length="0.005"/></geometry>')
    w('      <material name="grey"/>')
    w("    </visual>")
    w("  </link>")
    for name, parent, child, z, axis, lim, vel, eff in JOINTS:
        w(f'  <joint name="{name}" type="revolute">')
        w(f'    <parent link="{parent}"/>')
        w(f'    <child link="{child}"/>')
        w(f'    <origin xyz="0 0 {z}" rpy="0 0 0"/>')
        w(f'    <axis xyz="{axis}"/>')
        w(f'    <limit lower="{-lim * DEG!r}" upper="{lim * DEG!r}" velocity="{vel}" effort="{eff}"/>')
        w("  </joint>")
    w('  <joint name="flange_joint" type="fixed">')
    w('    <parent link="link7"/>')
    w('    <child link="flange"/>')
    w('    <origin xyz="0 0 0.07" rpy="0 0 0"/>')
    w("  </joint>")
    w("</robot>")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    with open(sys.argv[1], "w") as fh:
        fh.write(urdf_text())
