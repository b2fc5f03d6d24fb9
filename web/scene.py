"""The 3D scene, in the robot's `base` frame (z up).

Owns every scene node the dashboard draws and how each is updated:

* the floor grid and the base axes;
* the arm, from its URDF (`wiithrow.web.arm_view.ArmView`), following the measured joint state;
* `/link1`: a frame that turns with joint 1, carrying what is fixed to the link: the rig's cameras
  as frustums (placed by the calibration's K, R, t, or the nominal cameras before one), the trained
  area of the throw plane, and the calibration points (actual by forward kinematics, calculated by
  the stereo rig, joined by their residual vectors drawn `residual_scale` times longer);
* the tracked markers with their ids and short trails (in base, as they move);
* the target where the world says it is (an operator's drag handle is that browser's own:
  `wiithrow.web.controls`);
* the throw: the preview (ghost arm playing the planned motion, the ball's predicted arc and
  landing), then the ball flying, the measured flight path and landing with the error.

Updates are cheap and idempotent: a method that is called with what is already drawn sends
nothing, so the refresh loop can call them every tick.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import viser
import viser.transforms as vtf
from numpy.typing import NDArray

from wiithrow.web.arm_view import ArmView

MARKER_COLORS = np.array(
    [(255, 120, 40), (60, 200, 255), (200, 80, 255), (80, 220, 120), (255, 220, 60), (255, 90, 150)], dtype=np.uint8
)
TRAIL_S = 1.0  # trail length (s)
LABEL_POOL = 6  # marker labels kept (the rig reports at most 4 dots per camera)


def polyline_segments(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N - 1, 2, 3) segments joining consecutive points (N, 3)."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    return np.stack([p[:-1], p[1:]], axis=1)


def rotation_wxyz(R: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(vtf.SO3.from_matrix(np.asarray(R, dtype=float)).wxyz)


@dataclass(frozen=True)
class CameraPose:
    """A camera as the scene draws it: name, K, and R, t mapping link1 into the camera."""

    name: str
    K: NDArray[np.float64]
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    calibrated: bool
    width: int = 1024
    height: int = 768


@dataclass(frozen=True)
class PreviewDrawing:
    """A throw preview as the scene shows it: the planned joint motion sampled every `dt` s, the
    ball's position at the same instants (in the hand, then on its arc), the arc and the landing."""

    id: int
    dt: float
    q: NDArray[np.float64]  # (K, nq)
    ball: NDArray[np.float64]  # (K, 3)
    arc: NDArray[np.float64]  # (N, 3) the ball's predicted path from the release
    landing: NDArray[np.float64]  # (3,)
    release_time: float
    arc_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))  # (N,) s after the release

    @property
    def duration(self) -> float:
        return self.dt * (len(self.q) - 1)


def plain_lighting(scene: viser.SceneApi) -> None:
    """Light `scene` with viser's default lights without their shadows, and no environment map
    (no reflections). A browser that renders WebGL in software (a machine without a GPU, a remote
    desktop; Chromium's SwiftShader) pays for both on the CPU: shadows draw the scene a second time
    from the light, and the environment's reflections make every material's shader longer to
    compile, each time the scene gains a kind of object. Measured in headless Chromium on the 2-core
    machine, all of Chromium's processes during an 8-pose calibration on the dashboard: 1.5 cores
    with them, 1.0 without (docs/performance.md)."""
    scene.configure_default_lights(enabled=True, cast_shadow=False)
    scene.configure_environment_map(hdri=None)


def default_lighting(scene: viser.SceneApi) -> None:
    """Light `scene` as viser does by default: its lights with their shadows, the "warehouse"
    environment map (what `plain_lighting` takes away)."""
    scene.configure_default_lights(enabled=True, cast_shadow=True)
    scene.configure_environment_map(hdri="warehouse")


class SceneView:
    """The scene of one dashboard (see the module docstring)."""

    def __init__(
        self,
        server: viser.ViserServer,
        urdf_path: str,
        joint_names: Sequence[str],
        *,
        residual_scale: float = 20.0,
        plain: bool = False,
    ) -> None:
        self.server = server
        scene = server.scene
        scene.set_up_direction("+z")
        if plain:  # `plain_lighting`
            plain_lighting(scene)
        server.initial_camera.position = (-0.35, -1.45, 1.05)
        server.initial_camera.look_at = (0.85, 0.1, 0.3)
        scene.add_grid("/floor", width=6.0, height=6.0, cell_size=0.25, section_size=1.0, position=(1.0, 0.0, 0.0))
        scene.add_frame("/base", axes_length=0.25, axes_radius=0.008)
        self.arm = ArmView(server, urdf_path, joint_names, root="/arm")
        self.link1 = scene.add_frame("/link1", show_axes=False)
        self._link1_drawn: NDArray[np.float64] | None = None
        # shown over the arm while its state cannot be read: the pose drawn is the last one known
        self._arm_stale = scene.add_label(
            "/base/arm_stale", "", position=(0.0, 0.0, 1.1), anchor="bottom-center", visible=False
        )
        self.arm_stale_text: str | None = None
        self.residual_scale = float(residual_scale)

        # cameras
        self._frustums: list[tuple[viser.CameraFrustumHandle, viser.LabelHandle]] = []
        self._camera_key: object = None

        # markers
        self._points = scene.add_point_cloud(
            "/markers/points", np.zeros((1, 3)), (255, 120, 40), point_size=0.045, point_shape="circle", visible=False
        )
        self._trails = scene.add_line_segments(
            "/markers/trails", np.zeros((1, 2, 3)), (255, 120, 40), thickness=0.008, visible=False
        )
        self._labels = [
            scene.add_label(f"/markers/label{k}", "", visible=False, anchor="bottom-left") for k in range(LABEL_POOL)
        ]
        self._trail: dict[int, deque[tuple[float, NDArray[np.float64]]]] = {}
        self._markers_key: tuple[tuple[int, ...], NDArray[np.float64]] | None = None
        self._trail_points_drawn = 0

        # target
        self.target = scene.add_frame("/target", show_axes=False, visible=False)  # until a target exists
        self._target_ball = scene.add_icosphere("/target/ir", radius=0.035, color=(255, 60, 60))
        self._target_label = scene.add_label(
            "/target/label", "target", position=(0.0, 0.0, 0.07), anchor="bottom-center", visible=False
        )
        self._target_drawn = np.full(3, np.nan)

        # calibration points (link1)
        self._calibration_nodes: list[viser.SceneNodeHandle] = []

        # preview and throw
        self.ghost = ArmView(server, urdf_path, joint_names, root="/preview/ghost", color=(0.35, 0.65, 1.0, 0.35))
        self.ghost.visible = False
        self._ghost_ball = scene.add_icosphere("/preview/ball", radius=0.033, color=(120, 170, 255), visible=False)
        self._arc = scene.add_line_segments(
            "/preview/arc", np.zeros((1, 2, 3)), (60, 130, 255), thickness=0.01, visible=False
        )
        self._predicted = scene.add_icosphere("/preview/landing", radius=0.04, color=(60, 130, 255), visible=False)
        # below the sphere, the target's label above it: near the target they would overlap
        self._predicted_label = scene.add_label(
            "/preview/landing/label", "predicted landing", position=(0, 0, -0.06), anchor="top-center", visible=False
        )
        self._preview: PreviewDrawing | None = None
        self._preview_t0 = 0.0
        self._ball = scene.add_icosphere("/throw/ball", radius=0.033, color=(230, 240, 60), visible=False)
        self._flight = scene.add_line_segments(
            "/throw/flight", np.zeros((1, 2, 3)), (230, 200, 40), thickness=0.008, visible=False
        )
        self._landing = scene.add_icosphere("/throw/landing", radius=0.03, color=(40, 220, 90), visible=False)
        # below the landing, so that it does not cover the target's label above it
        self._landing_label = scene.add_label(
            "/throw/landing/label", "", position=(0, 0, -0.05), anchor="top-center", visible=False
        )
        self._area: viser.SceneNodeHandle | None = None

    # -- the arm and link1 --------------------------------------------------------------------------

    def update_arm(self, q: NDArray[np.float64], link1: NDArray[np.float64], *, fault: str | None = None) -> None:
        """Pose the arm and link1; `fault`: why the arm's state could not be read (q is then its
        last known pose, marked as such over the arm), None when q is measured now."""
        text = None if fault is None else f"arm state unreadable ({fault}): last known pose"
        if text != self.arm_stale_text:
            self.arm_stale_text = text
            self._arm_stale.text = text or ""
            self._arm_stale.visible = text is not None
        self.arm.update(q)
        # as the arm's joints: a change below the threshold (the 1 mrad tracking noise) is not sent
        drawn = self._link1_drawn
        turned = drawn is None or np.max(np.abs(link1[:3, :3] - drawn[:3, :3])) > self.arm.threshold_rad
        moved = drawn is None or np.max(np.abs(link1[:3, 3] - drawn[:3, 3])) > 1e-3
        if turned:
            self.link1.wxyz = rotation_wxyz(link1[:3, :3])
        if moved:
            self.link1.position = link1[:3, 3]
        if turned or moved:
            self._link1_drawn = link1.copy()

    def set_cameras(self, cameras: Sequence[CameraPose]) -> None:
        """Draw the rig's cameras (in link1); redrawn only when they change."""
        key = tuple((c.name, c.calibrated, np.round(c.R, 6).tobytes(), np.round(c.t, 6).tobytes()) for c in cameras)
        if key == self._camera_key:
            return
        self._camera_key = key
        for frustum, label in self._frustums:
            label.remove()
            frustum.remove()
        self._frustums = []
        for c in cameras:
            fy, fx = float(c.K[1, 1]), float(c.K[0, 0])
            fov = 2.0 * np.arctan(0.5 * c.height / fy)
            aspect = (c.width / fx) / (c.height / fy)
            center = -c.R.T @ c.t
            color = (40, 160, 90) if c.calibrated else (150, 150, 150)
            frustum = self.server.scene.add_camera_frustum(
                f"/link1/{c.name}",
                fov=float(fov),
                aspect=float(aspect),
                scale=0.12,
                thickness=0.006,
                color=color,
                wxyz=rotation_wxyz(c.R.T),
                position=center,
            )
            text = f"{c.name} ({'calibrated' if c.calibrated else 'nominal'})"
            label = self.server.scene.add_label(
                f"/link1/{c.name}/label", text, position=(0.0, -0.05, 0.0), anchor="bottom-center"
            )
            self._frustums.append((frustum, label))

    def set_trained_area(self, vertices_xz: NDArray[np.float64] | None) -> None:
        """The trained area of the throw plane (a polygon in link1's x, z at y = 0)."""
        if self._area is not None:
            self._area.remove()
            self._area = None
        if vertices_xz is None or len(vertices_xz) < 3:
            return
        v = np.asarray(vertices_xz, dtype=float)
        ring = np.column_stack([v[:, 0], np.zeros(len(v)), v[:, 1]])
        ring = np.vstack([ring, ring[:1]])
        self._area = self.server.scene.add_line_segments(
            "/link1/trained_area", polyline_segments(ring), (120, 120, 220), thickness=0.006
        )

    # -- markers -------------------------------------------------------------------------------------

    def update_markers(
        self,
        t: float,
        ids: NDArray[np.int64],
        positions: NDArray[np.float64],
        *,
        trails: bool = True,
        tolerance_m: float = 0.002,
    ) -> None:
        """The tracked markers now (base); keeps each id's trail for TRAIL_S and redraws the trails
        if `trails`. Nothing is sent while the same markers stay within `tolerance_m` of where
        they were drawn."""
        for i, p in zip(ids.tolist(), positions):
            self._trail.setdefault(i, deque()).append((t, p.copy()))
        for i in list(self._trail):
            trail = self._trail[i]
            while trail and t - trail[0][0] > TRAIL_S:
                trail.popleft()
            if not trail:
                del self._trail[i]
        key_ids = tuple(ids.tolist())
        drawn = self._markers_key
        same_ids = drawn is not None and drawn[0] == key_ids
        if (
            drawn is not None
            and same_ids
            and (not len(positions) or np.max(np.abs(drawn[1] - positions)) < tolerance_m)
        ):
            if trails and sum(map(len, self._trail.values())) != self._trail_points_drawn:
                self._draw_trails()  # a trail grew or faded
            return
        self._markers_key = (key_ids, positions.copy())
        if len(ids):
            self._points.points = positions.astype(np.float32)
            if not same_ids:
                self._points.colors = MARKER_COLORS[np.asarray(ids) % len(MARKER_COLORS)]
            if not self._points.visible:
                self._points.visible = True
        elif self._points.visible:
            self._points.visible = False
        if trails or not same_ids:
            self._draw_trails()
        for k, label in enumerate(self._labels):
            if k < len(ids):
                text = f"#{int(ids[k])}"
                if label.text != text:
                    label.text = text
                label.position = positions[k] + np.array([0.03, 0.0, 0.05])
                if not label.visible:
                    label.visible = True
            elif label.visible:
                label.visible = False

    def _draw_trails(self) -> None:
        self._trail_points_drawn = sum(map(len, self._trail.values()))
        segments, seg_colors = [], []
        for i, trail in self._trail.items():
            if len(trail) >= 2:
                s = polyline_segments(np.array([p for _, p in trail]))
                segments.append(s)
                seg_colors.append(np.broadcast_to(MARKER_COLORS[i % len(MARKER_COLORS)], s.shape))
        if segments:
            points = np.concatenate(segments).astype(np.float32)
            colors = np.concatenate(seg_colors)
            if self._trails.points.shape != points.shape or not np.array_equal(self._trails.colors, colors):
                self._trails.colors = colors
            self._trails.points = points
            if not self._trails.visible:
                self._trails.visible = True
        elif self._trails.visible:
            self._trails.visible = False

    # -- target ----------------------------------------------------------------------------------------

    def update_target(self, position: NDArray[np.float64]) -> None:
        """Where the target is (base; NaN while unlit, or unknown): the target, its label and
        nothing else of it is drawn only where it is, hidden while there is none (never left at
        the base's origin, where its frame starts)."""
        lit = bool(np.isfinite(position).all())
        if self.target.visible != lit:
            self.target.visible = self._target_label.visible = lit
        if lit and not np.allclose(position, self._target_drawn, atol=1e-3):
            self.target.position = position
            self._target_drawn = position.copy()

    @property
    def target_drawn(self) -> NDArray[np.float64]:
        """Where the target was last drawn (NaN before it was lit)."""
        return self._target_drawn.copy()

    @property
    def target_shown(self) -> NDArray[np.float64]:
        """Where the target is drawn now: NaN while it is hidden (unlit, e.g. during a calibration)."""
        return self._target_drawn.copy() if self.target.visible else np.full(3, np.nan)

    # -- calibration -------------------------------------------------------------------------------------

    def set_calibration_points(
        self,
        actual: NDArray[np.float64] | None,
        calculated: NDArray[np.float64] | None,
        worst: Sequence[tuple[int, float]] = (),
    ) -> None:
        """Calibration points in link1: actual (FK) green, calculated (stereo) red at the end of the
        residual vector drawn `residual_scale` times longer; the worst points labelled."""
        for node in self._calibration_nodes:
            node.remove()
        self._calibration_nodes = []
        if actual is None or calculated is None or not len(actual):
            return
        ok = np.isfinite(calculated).all(axis=1)
        a, c = actual[ok], calculated[ok]
        shown = a + self.residual_scale * (c - a)
        scene = self.server.scene
        self._calibration_nodes += [
            scene.add_point_cloud(
                "/link1/calibration/actual", a.astype(np.float32), (40, 200, 80), point_size=0.018, point_shape="circle"
            ),
            scene.add_point_cloud(
                "/link1/calibration/calculated",
                shown.astype(np.float32),
                (230, 60, 60),
                point_size=0.014,
                point_shape="diamond",
            ),
            scene.add_line_segments(
                "/link1/calibration/residuals", np.stack([a, shown], axis=1), (230, 60, 60), thickness=0.003
            ),
        ]
        for index, error_m in worst:
            if 0 <= index < len(actual):
                self._calibration_nodes.append(
                    scene.add_label(
                        f"/link1/calibration/worst{index}",
                        f"pose {index + 1}: {1e3 * error_m:.1f} mm",  # numbered from 1, as everywhere
                        position=actual[index] + np.array([0.0, 0.0, 0.03]),
                        anchor="bottom-center",
                    )
                )

    # -- preview -------------------------------------------------------------------------------------------

    def set_preview(self, preview: PreviewDrawing | None, *, keep_arc: bool = False) -> None:
        """Show a preview (the ghost plays it in a loop) or hide it (`keep_arc`: the arc and the
        predicted landing stay, as while its throw runs)."""
        if preview is not None and self._preview is not None and preview.id == self._preview.id:
            return
        self._preview = preview
        if preview is None:
            self.ghost.visible = False
            self._ghost_ball.visible = False
            if not keep_arc:
                self._arc.visible = self._predicted.visible = self._predicted_label.visible = False
            return
        self._preview_t0 = time.monotonic()
        self._arc.points = polyline_segments(preview.arc).astype(np.float32)
        self._arc.visible = True
        self._predicted.position = preview.landing
        self._predicted.visible = self._predicted_label.visible = True
        self.ghost.update(preview.q[0], force=True)
        self.ghost.visible = True
        self._ghost_ball.visible = True

    def animate_preview(self, now: float | None = None) -> None:
        """Advance the ghost's loop: the planned motion, then a pause of 0.6 s."""
        p = self._preview
        if p is None:
            return
        now = time.monotonic() if now is None else now
        t = (now - self._preview_t0) % (p.duration + 0.6)
        k = min(int(t / p.dt), len(p.q) - 1)
        self.ghost.update(p.q[k])
        self._ghost_ball.position = p.ball[k]

    # -- throw ------------------------------------------------------------------------------------------------

    def show_ball(self, position: NDArray[np.float64] | None) -> None:
        """The real ball (during a throw), or hide it."""
        if position is None:
            if self._ball.visible:
                self._ball.visible = False
            return
        self._ball.position = position
        if not self._ball.visible:
            self._ball.visible = True

    def set_throw_result(
        self, flight: NDArray[np.float64] | None, landing: NDArray[np.float64] | None, text: str = ""
    ) -> None:
        """The last throw's flight path and landing (base), with a label; None hides them."""
        if flight is None or landing is None:
            self._flight.visible = self._landing.visible = self._landing_label.visible = False
            return
        self._flight.points = polyline_segments(flight).astype(np.float32)
        self._flight.visible = True
        self._landing.position = landing
        self._landing.visible = True
        self._landing_label.text = text
        self._landing_label.visible = True
        self._predicted_label.visible = False  # the result's label says it; the sphere stays

    def set_result_label(self, text: str) -> None:
        """The shown throw result's label, anew (its landing measured anew); nothing if none is shown."""
        if self._landing_label.visible and self._landing_label.text != text:
            self._landing_label.text = text
