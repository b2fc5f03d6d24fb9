"""The arm in the scene: its URDF drawn by `viser.extras.ViserUrdf`, posed from joint angles.

Owns `ArmView`. The geometry and the frame tree come from `ViserUrdf` (the PA-10 URDF has simple
cylinders). Posing is done here rather than with `ViserUrdf.update_cfg`, which runs yourdfpy's
scene-graph forward kinematics and costs about 6 ms per call (measured), too much for a 20 Hz
refresh beside a 100 Hz tracking loop. Every joint frame of the URDF is the joint's fixed origin
followed by a rotation about its axis, so only its orientation changes with the angle:

    wxyz_j(q_j) = wxyz(origin_j) * (cos(q_j / 2), sin(q_j / 2) axis_j)

and a joint whose angle moved by less than `threshold_rad` since it was last drawn (the simulated
arm's 1 mrad tracking noise at rest) is not re-sent. Falls back to `update_cfg` if the ViserUrdf of
the installed viser does not expose its frames the way this expects.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import viser
import viser.transforms as vtf
from numpy.typing import NDArray
from viser.extras import ViserUrdf


def quaternion_multiply(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product of two wxyz quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


class ArmView:
    """An arm drawn under the scene node `root` (a frame this creates, so it can be hidden).

    `joint_names`: the order of the q vectors passed to `update` (the arm model's joints);
    `color`: None for the URDF's materials, or an (r, g, b[, a]) override in 0-1 (a ghost).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        urdf_path: str | Path,
        joint_names: Sequence[str],
        *,
        root: str = "/arm",
        color: tuple[float, float, float] | tuple[float, float, float, float] | None = None,
        threshold_rad: float = 0.004,
    ) -> None:
        self.root = server.scene.add_frame(root, show_axes=False)
        self.urdf = ViserUrdf(server, Path(urdf_path), root_node_name=root, mesh_color_override=color)
        self.threshold_rad = float(threshold_rad)
        self._index = {name: i for i, name in enumerate(joint_names)}
        self._drawn: NDArray[np.float64] | None = None
        self._joints: list[tuple[int, NDArray[np.float64], NDArray[np.float64], viser.FrameHandle]] = []
        frames = getattr(self.urdf, "_joint_frames", None)
        joints = getattr(self.urdf, "_joint_map_values", None)
        self._fast = frames is not None and joints is not None and len(frames) == len(joints)
        if frames is not None and joints is not None and self._fast:
            for joint, frame in zip(joints, frames):
                origin = np.eye(4) if getattr(joint, "origin", None) is None else np.asarray(joint.origin, float)
                q0 = vtf.SO3.from_matrix(origin[:3, :3]).wxyz
                frame.position = origin[:3, 3]
                frame.wxyz = q0
                if joint.type in ("revolute", "continuous") and joint.name in self._index:
                    axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
                    self._joints.append(
                        (self._index[joint.name], np.asarray(q0, float), axis / np.linalg.norm(axis), frame)
                    )

    @property
    def visible(self) -> bool:
        return bool(self.root.visible)

    @visible.setter
    def visible(self, on: bool) -> None:
        if bool(self.root.visible) != bool(on):
            self.root.visible = bool(on)

    def update(self, q: NDArray[np.float64], *, force: bool = False) -> int:
        """Pose the arm at joint angles q; returns how many joint frames were re-sent."""
        q = np.asarray(q, dtype=float)
        if not self._fast:
            if force or self._drawn is None or np.max(np.abs(q - self._drawn)) > self.threshold_rad:
                self.urdf.update_cfg(q)
                self._drawn = q.copy()
                return len(q)
            return 0
        if self._drawn is None:
            self._drawn = np.full(q.shape, np.inf)
        sent = 0
        for i, q0, axis, frame in self._joints:
            if not force and abs(q[i] - self._drawn[i]) <= self.threshold_rad:
                continue
            half = 0.5 * q[i]
            frame.wxyz = quaternion_multiply(q0, np.concatenate([[np.cos(half)], np.sin(half) * axis]))
            self._drawn[i] = q[i]
            sent += 1
        return sent
