"""Generator of robot/urdf/ur5e.urdf: `python robot/urdf/make_ur5e.py robot/urdf/ur5e.urdf`.

Written for wiithrow from Universal Robots' published figures for the UR5e (no file of theirs is
copied): the standard DH table of UR's article "DH parameters for calculations of kinematics and
dynamics" (universal-robots.com),

    d = (0.1625, 0, 0, 0.1333, 0.0997, 0.0996) m,  a = (0, -0.425, -0.3922, 0, 0, 0) m,
    alpha = (pi/2, 0, 0, pi/2, -pi/2, 0),

with the link masses and centres of mass of the same article (in DH link frames), and the
limits of the UR5e's technical specification: every joint +-360 degrees and 180 degrees/s;
torques 150 N m (base, shoulder, elbow) and 28 N m (wrists), from UR's article "Max. joint
torques". Inertia tensors are not published: each is a solid cylinder along its link's DH
offset with the published mass, about the published centre of mass (plausible, not measured).

Link frames: the URDF link of joint k is DH frame k-1 turned by q_k about its z axis, so joint
k's origin in its parent link is Tz(d_{k-1}) Tx(a_{k-1}) Rx(alpha_{k-1}) (xyz "a 0 d", rpy
"alpha 0 0"), its axis z; `tool0` (the flange, z out of the tool) is DH frame 6. `base` is the
controller's base frame (DH frame 0), not ROS-Industrial's `base_link` (turned by pi about z).
At q = 0 the arm stretches along -x of base. Not imported by the package.
"""

import sys

import numpy as np

# joint name, child link, d (m), a (m), alpha (rad), velocity (rad/s), effort (N m)
DH = [
    ("shoulder_pan_joint", "shoulder_link", 0.1625, 0.0, np.pi / 2, np.pi, 150.0),
    ("shoulder_lift_joint", "upper_arm_link", 0.0, -0.425, 0.0, np.pi, 150.0),
    ("elbow_joint", "forearm_link", 0.0, -0.3922, 0.0, np.pi, 150.0),
    ("wrist_1_joint", "wrist_1_link", 0.1333, 0.0, np.pi / 2, np.pi, 28.0),
    ("wrist_2_joint", "wrist_2_link", 0.0997, 0.0, -np.pi / 2, np.pi, 28.0),
    ("wrist_3_joint", "wrist_3_link", 0.0996, 0.0, 0.0, np.pi, 28.0),
]
# UR's published link masses (kg) and centres of mass (m, in DH frame k)
MASS = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
COM = (
    (0, -0.02561, 0.00193),
    (0.2125, 0, 0.11336),
    (0.15, 0, 0.0265),
    (0, -0.0018, 0.01634),
    (0, 0.0018, 0.01634),
    (0, 0, -0.001159),
)
RADIUS = (0.06, 0.054, 0.045, 0.038, 0.038, 0.032)  # m, of the drawn cylinders (and the inertia's)
LIMIT = 2 * np.pi  # +-360 degrees
BASE_MASS = 4.0  # kg, the base flange (not published separately; plausible)


def f(x: float) -> str:
    return f"{x:.6g}"


def rx(alpha: float) -> np.ndarray:
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def urdf_text() -> str:
    """The URDF of the UR5e, as text."""
    out: list[str] = []
    w = out.append
    w('<?xml version="1.0"?>')
    w("<!--")
    w("  Universal Robots UR5e, written for wiithrow by robot/urdf/make_ur5e.py from UR's published DH table")
    w("  (d = 0.1625, 0, 0, 0.1333, 0.0997, 0.0996 m; a = 0, -0.425, -0.3922, 0, 0, 0 m;")
    w("  alpha = pi/2, 0, 0, pi/2, -pi/2, 0), link masses and centres of mass, and the technical")
    w("  specification's limits (+-360 deg, 180 deg/s per joint; 150/150/150/28/28/28 N m).")
    w("  Link k's frame is DH frame k-1 turned by q_k; tool0 (the flange) is DH frame 6; base is the")
    w("  controller's base frame. Inertias: solid cylinders with the published masses (plausible).")
    w("-->")
    w('<robot name="ur5e">')
    w('  <material name="grey"><color rgba="0.55 0.57 0.60 1"/></material>')
    w('  <material name="blue"><color rgba="0.30 0.55 0.80 1"/></material>')
    w('  <link name="base">')
    w("    <inertial>")
    w('      <origin xyz="0 0 0.03" rpy="0 0 0"/>')
    w(f'      <mass value="{BASE_MASS}"/>')
    w('      <inertia ixx="0.0066" ixy="0" ixz="0" iyy="0.0066" iyz="0" izz="0.0072"/>')
    w("    </inertial>")
    w(
        '    <visual><origin xyz="0 0 0.03" rpy="0 0 0"/><geometry><cylinder radius="0.06" length="0.06"/></geometry>'
        '<material name="grey"/></visual>'
    )
    w("  </link>")
    for k, (_, link, d, a, alpha, _, _) in enumerate(DH):
        # in link k's frame (DH frame k-1 turned by q_k) the next joint is at (a, 0, d), and DH frame k
        # is that point turned by Rx(alpha)
        seg = np.array([a, 0.0, d])
        com = seg + rx(alpha) @ np.asarray(COM[k], float)
        m, r = MASS[k], RADIUS[k]
        h = max(float(np.linalg.norm(seg)), 2 * r)
        along_x = abs(a) > abs(d)
        ia, it = 0.5 * m * r * r, m * (3 * r * r + h * h) / 12
        ixx, iyy, izz = (ia, it, it) if along_x else (it, it, ia)
        centre = 0.5 * seg
        rpy = "0 1.5707963267948966 0" if along_x else "0 0 0"
        w(f'  <link name="{link}">')
        w("    <inertial>")
        w(f'      <origin xyz="{f(com[0])} {f(com[1])} {f(com[2])}" rpy="0 0 0"/>')
        w(f'      <mass value="{m}"/>')
        w(f'      <inertia ixx="{f(ixx)}" ixy="0" ixz="0" iyy="{f(iyy)}" iyz="0" izz="{f(izz)}"/>')
        w("    </inertial>")
        for tag in ("visual", "collision"):
            w(f"    <{tag}>")
            w(f'      <origin xyz="{f(centre[0])} {f(centre[1])} {f(centre[2])}" rpy="{rpy}"/>')
            w(f'      <geometry><cylinder radius="{r}" length="{f(h)}"/></geometry>')
            if tag == "visual":
                w(f'      <material name="{"blue" if k % 2 else "grey"}"/>')
            w(f"    </{tag}>")
        w("  </link>")
    w('  <link name="tool0"/>')
    parent = "base"
    xyz, rpy = "0 0 0", "0 0 0"
    for name, link, d, a, alpha, vel, eff in DH:
        w(f'  <joint name="{name}" type="revolute">')
        w(f'    <parent link="{parent}"/>')
        w(f'    <child link="{link}"/>')
        w(f'    <origin xyz="{xyz}" rpy="{rpy}"/>')
        w('    <axis xyz="0 0 1"/>')
        w(f'    <limit lower="{-LIMIT!r}" upper="{LIMIT!r}" velocity="{vel!r}" effort="{eff}"/>')
        w("  </joint>")
        parent, xyz, rpy = link, f"{f(a)} 0 {f(d)}", f"{alpha!r} 0 0"
    w('  <joint name="tool0_joint" type="fixed">')
    w(f'    <parent link="{parent}"/>')
    w('    <child link="tool0"/>')
    w(f'    <origin xyz="{xyz}" rpy="{rpy}"/>')
    w("  </joint>")
    w("</robot>")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    with open(sys.argv[1], "w") as fh:
        fh.write(urdf_text())
