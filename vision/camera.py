"""The Wiimote IR camera as a pinhole model: what it reports when it looks at IR sources.

A point X (in the camera's mount frame, e.g. `link1`) maps to camera coordinates and pixels by

    x_cam = R X + t,            [u, v, 1]^T ~ K x_cam,      K = [[f, 0, cx], [0, f, cy], [0, 0, 1]]

so P = K [R | t] is the camera's 3x4 projection matrix. Camera axes follow the usual convention:
z along the optical axis, x to the right of the image, y down it.

The real camera does more than project. Its 128x96 sensor is interpolated 8x to 1024x768 and the
remote sends integer pixels; it reports at most four blobs; a point behind it or outside its field
of view is simply absent. `observe` reproduces that: Gaussian pixel noise (sigma a parameter)
before rounding to integers, NaN for anything not seen, at most `MAX_BLOBS` dots (the ones found
first, i.e. the lowest source indices, are kept), optional random drop-outs. Randomness comes from
the `numpy.random.Generator` passed in.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.geometry import project

IMAGE_WIDTH = 1024
IMAGE_HEIGHT = 768
MAX_BLOBS = 4
DEFAULT_FOCAL_PX = 1300.0
DEFAULT_CENTER_PX = (512.0, 384.0)
MAX_BLOB_SIZE = 15
#: A point closer to the camera's focal plane than this (metres), or behind it, is not seen.
MIN_DEPTH_M = 1e-9


def look_at_rotation(forward: ArrayLike, up: ArrayLike = (0.0, 0.0, 1.0)) -> NDArray[np.float64]:
    """Rotation R (frame -> camera) of a camera whose optical axis points along `forward`.

    The image's x axis is `forward x up` (to the right when `up` is up), its y axis
    `forward x x` (down). Raises ValueError when `forward` is parallel to `up`.
    """
    z = np.asarray(forward, dtype=float)
    z = z / np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, dtype=float))
    norm = np.linalg.norm(x)
    if norm < 1e-9:
        raise ValueError("look_at_rotation: the optical axis is parallel to 'up'; choose another 'up'")
    x /= norm
    y = np.cross(z, x)
    return np.vstack([x, y, z])  # rows are the camera axes expressed in the frame


def intrinsic_matrix(focal_px: float, center_px: tuple[float, float]) -> NDArray[np.float64]:
    """K for square pixels and no skew."""
    return np.array([[focal_px, 0.0, center_px[0]], [0.0, focal_px, center_px[1]], [0.0, 0.0, 1.0]])


def pitched_forward(pitch_down_rad: float, yaw_rad: float = 0.0) -> NDArray[np.float64]:
    """Unit vector along +x of the frame, turned by `yaw` about z and pitched down by `pitch_down`."""
    c = np.cos(pitch_down_rad)
    return np.array([c * np.cos(yaw_rad), c * np.sin(yaw_rad), -np.sin(pitch_down_rad)])


@dataclass(frozen=True)
class WiimoteCamera:
    """A Wiimote IR camera placed in a named frame.

    `R`, `t` map points of `frame` into the camera (x_cam = R X + t); `K` holds the intrinsics.
    """

    K: NDArray[np.float64]
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    frame: str = "link1"
    name: str = "cam0"
    width: int = IMAGE_WIDTH
    height: int = IMAGE_HEIGHT
    blob_size_at_1m: float = 3.0
    _P: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _K0: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _half: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _rows: tuple[tuple[float, float, float, float], ...] = field(init=False, repr=False, compare=False)
    _intrinsics: tuple[float, float, float, float] = field(init=False, repr=False, compare=False)
    _pinhole_k: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=float).reshape(3, 3)
        R = np.asarray(self.R, dtype=float).reshape(3, 3)
        t = np.asarray(self.t, dtype=float).reshape(3)
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("WiimoteCamera: R must be a proper rotation matrix")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "_P", K @ np.hstack([R, t[:, None]]))
        object.__setattr__(self, "_K0", np.hstack([K, np.zeros((3, 1))]))
        # the sensor's half extent, (width - 1) / 2 and (height - 1) / 2: on it iff |pixel - half| <= half
        object.__setattr__(self, "_half", np.array([(self.width - 1) / 2.0, (self.height - 1) / 2.0]))
        # plain floats for `observe_few`: the rows of [R | t] and (fx, cx, fy, cy) of K
        object.__setattr__(self, "_rows", tuple(tuple(row) for row in np.hstack([R, t[:, None]]).tolist()))
        object.__setattr__(self, "_intrinsics", (float(K[0, 0]), float(K[0, 2]), float(K[1, 1]), float(K[1, 2])))
        object.__setattr__(self, "_pinhole_k", bool(K[0, 1] == K[1, 0] == K[2, 0] == K[2, 1] == 0 and K[2, 2] == 1))

    @classmethod
    def at(
        cls,
        position: ArrayLike,
        forward: ArrayLike,
        *,
        up: ArrayLike = (0.0, 0.0, 1.0),
        focal_px: float = DEFAULT_FOCAL_PX,
        center_px: tuple[float, float] = DEFAULT_CENTER_PX,
        frame: str = "link1",
        name: str = "cam0",
    ) -> WiimoteCamera:
        """A camera at `position` (in `frame`, metres) whose optical axis points along `forward`."""
        R = look_at_rotation(forward, up)
        c = np.asarray(position, dtype=float)
        return cls(K=intrinsic_matrix(focal_px, center_px), R=R, t=-R @ c, frame=frame, name=name)

    @property
    def P(self) -> NDArray[np.float64]:
        """The 3x4 projection matrix K [R | t]."""
        return self._P

    @property
    def pinhole(self) -> bool:
        """K is a pinhole's (no skew, last row (0, 0, 1)): the third row of P X is the depth."""
        return self._pinhole_k

    @property
    def center(self) -> NDArray[np.float64]:
        """The optical centre in `frame` (metres)."""
        return -self.R.T @ self.t

    def to_camera(self, points: ArrayLike) -> NDArray[np.float64]:
        """Points (N, 3) of `frame` in camera coordinates (N, 3)."""
        X = np.asarray(points, dtype=float).reshape(-1, 3)
        return X @ self.R.T + self.t

    def project(self, points: ArrayLike) -> NDArray[np.float64]:
        """Ideal (noise-free, unrounded) pixels (N, 2) of points (N, 3); NaN behind the camera.

        Computed as x_cam = R X + t, then the pixels of x_cam under K [I | 0] (`geometry.project`),
        which rounds like the pinhole formula rather than like P X.
        """
        return project(self._K0, self.to_camera(points), min_depth=MIN_DEPTH_M)

    def in_view(self, pixels: ArrayLike, margin_px: float = 0.0) -> NDArray[np.bool_]:
        """Which pixels (N, 2) lie on the sensor `margin_px` inside its edges
        (margin..width-1-margin, margin..height-1-margin)."""
        uv = np.asarray(pixels, dtype=float).reshape(-1, 2)
        with np.errstate(invalid="ignore"):
            inside: NDArray[np.bool_] = (
                np.isfinite(uv).all(axis=1)
                & (uv[:, 0] >= margin_px)
                & (uv[:, 0] <= self.width - 1 - margin_px)
                & (uv[:, 1] >= margin_px)
                & (uv[:, 1] <= self.height - 1 - margin_px)
            )
        return inside

    def observe(
        self,
        points: ArrayLike,
        rng: np.random.Generator,
        *,
        sigma_px: float = 0.5,
        dropout: float = 0.0,
        max_blobs: int | None = MAX_BLOBS,
    ) -> NDArray[np.float64]:
        """What the camera reports for IR sources at `points` (N, 3): pixels (N, 2), NaN if unseen.

        Noise N(0, sigma_px^2) is added to the ideal pixels, which are then rounded to integers (the
        remote sends integers); a source behind the camera or off the sensor is NaN; each seen source
        is dropped with probability `dropout`; of the rest only the first `max_blobs` are kept
        (`None` keeps all, for calibration studies with one marker at a time).
        """
        uv, _ = self.observe_sized(points, rng, sigma_px=sigma_px, dropout=dropout, max_blobs=max_blobs)
        return uv

    def observe_sized(
        self,
        points: ArrayLike,
        rng: np.random.Generator,
        *,
        sigma_px: float = 0.5,
        dropout: float = 0.0,
        max_blobs: int | None = MAX_BLOBS,
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """`observe(points, ...)` and `blob_sizes(points)` in one pass: the points are taken into
        the camera once (a simulated remote asks for both 100 times a second). The same numbers,
        the same draws from `rng` in the same order, as the two calls one after the other.

        Pixels of the points in front (depth > MIN_DEPTH_M) are x_cam's under K (K [I | 0] of
        `project`: the same products, without adding its zero column); the others are NaN.
        """
        X = np.asarray(points, dtype=float).reshape(-1, 3)
        xc = X @ self.R.T + self.t
        depth = xc[:, 2]
        front = depth > MIN_DEPTH_M
        safe_depth = np.where(front, depth, 1.0)  # no division by zero behind the camera
        uv = (xc @ self.K.T)[:, :2] / safe_depth[:, None]
        if sigma_px > 0:
            uv = uv + rng.normal(0.0, sigma_px, size=uv.shape)
        uv = np.rint(uv)
        # on the sensor (`in_view`): |pixel - half| <= half, exact for these whole numbers; NaN and
        # inf compare False, without a warning (numpy >= 2)
        on_sensor = np.abs(uv - self._half) <= self._half
        seen = front & on_sensor[:, 0] & on_sensor[:, 1]
        if dropout > 0:
            seen &= rng.random(seen.shape[0]) >= dropout
        if max_blobs is not None:
            seen &= np.cumsum(seen) <= max_blobs
        uv[~seen] = np.nan
        return uv, _sizes_at(safe_depth, front, self.blob_size_at_1m)

    def observe_few(
        self,
        points: Sequence[Sequence[float]],
        rng: np.random.Generator,
        *,
        sigma_px: float = 0.5,
        dropout: float = 0.0,
        max_blobs: int | None = MAX_BLOBS,
    ) -> tuple[list[tuple[int, int] | None], list[int]]:
        """`observe_sized` for a few points (a remote's <= 4 LEDs, 100 times a second) in plain
        Python floats: each seen point's integer pixel (None if unseen) and every point's blob size.

        The same draws from `rng` in the same order (one `normal` of shape (N, 2), then one
        `random(N)` if `dropout`), the same formulas, K applied as u = (fx x + cx z) / z,
        v = (fy y + cy z) / z. numpy's matrix products may round a last bit differently, so a
        pixel can differ from `observe_sized`'s only where noise lands on an exact .5 tie (the
        tests compare the two on many random points). The blob is on the sensor iff its rounded
        pixel is within 0..width-1, 0..height-1 (`in_view`); `round` rounds half to even like
        `np.rint`.
        """
        if not self._pinhole_k:  # skew or a general last row: the numpy formulas
            uv, size_array = self.observe_sized(points, rng, sigma_px=sigma_px, dropout=dropout, max_blobs=max_blobs)
            return [None if u != u else (int(u), int(v)) for u, v in uv.tolist()], size_array.tolist()
        n = len(points)
        (r00, r01, r02, t0), (r10, r11, r12, t1), (r20, r21, r22, t2) = self._rows
        fx, cx, fy, cy = self._intrinsics
        noise = rng.normal(0.0, sigma_px, size=(n, 2)).tolist() if sigma_px > 0 else [[0.0, 0.0]] * n
        keep = (rng.random(n) >= dropout).tolist() if dropout > 0 else [True] * n
        x_max, y_max = self.width - 1, self.height - 1
        size_at_1m = self.blob_size_at_1m
        pixels: list[tuple[int, int] | None] = []
        sizes: list[int] = []
        n_seen = 0
        for (x, y, z), (nu, nv), kept in zip(points, noise, keep, strict=True):
            depth = r20 * x + r21 * y + r22 * z + t2
            if not depth > MIN_DEPTH_M:  # behind the camera or NaN
                pixels.append(None)
                sizes.append(0)
                continue
            sizes.append(min(max(round(size_at_1m / depth), 1), MAX_BLOB_SIZE))
            xc = r00 * x + r01 * y + r02 * z + t0
            yc = r10 * x + r11 * y + r12 * z + t1
            u = (fx * xc + cx * depth) / depth + nu
            v = (fy * yc + cy * depth) / depth + nv
            # -0.5 <= u <= x_max + 0.5 holds for every u that rounds into 0..x_max, and for no NaN or inf
            if not (kept and -0.5 <= u <= x_max + 0.5 and -0.5 <= v <= y_max + 0.5):
                pixels.append(None)
                continue
            pu, pv = round(u), round(v)
            if pu > x_max or pv > y_max or (max_blobs is not None and n_seen >= max_blobs):
                pixels.append(None)
                continue
            n_seen += 1
            pixels.append((pu, pv))
        return pixels, sizes

    def blob_sizes(self, points: ArrayLike) -> NDArray[np.int64]:
        """Blob size (0-15, as the extended and full IR formats report it) of sources at `points`.

        The size shrinks with depth: round(blob_size_at_1m / depth), at least 1, at most 15; 0 for a
        source behind the camera.
        """
        depth = self.to_camera(points)[:, 2]
        front = depth > MIN_DEPTH_M
        return _sizes_at(np.where(front, depth, 1.0), front, self.blob_size_at_1m)


def _sizes_at(safe_depth: NDArray[np.float64], front: NDArray[np.bool_], size_at_1m: float) -> NDArray[np.int64]:
    """round(size_at_1m / depth) within 1..MAX_BLOB_SIZE where `front`, else 0 (`blob_sizes`);
    `safe_depth` is the depth where `front` and anything non-zero elsewhere."""
    size = np.minimum(np.maximum(np.rint(size_at_1m / safe_depth), 1), MAX_BLOB_SIZE)  # np.clip costs twice
    sizes: NDArray[np.int64] = np.where(front, size, 0).astype(np.int64)
    return sizes
