"""A calibrated rig of C >= 2 cameras, and its files.

Our own file is versioned JSON (kind "wiithrow.calibration"), written atomically: the frame the
cameras are calibrated in (`link1` for a rig on the robot), the arm whose link1 that is (`arm`: a
robot calibration's, or a wand calibration given the robot's frame; null for a frame that is no
arm's, a camera's or an L-frame's), and per camera P, its decomposition K, R, t, the image size,
the fit's residuals and method; plus the leave-one-out 3D error when known. A file without `arm`
(written before it was recorded) takes the arm its `meta.arm` names, where a robot calibration
always recorded it; without either it is taken to be of the arm at hand, and the commands that
move an arm say so (`wiithrow.app.worlds.base.check_calibration_fits`). A file is at most
`files.CALIBRATION_SIZE` (64 MiB): a larger one is refused before it is read, and a calibration
that would be larger is not written. Every number lies within `dlt.MAX_CALIBRATION_NUMBER`.

For interoperability, the 11-coefficient DLT CSV of DLTdv and easyWand: 11 rows, one column per
camera, comma separated, coefficients L1..L11 of

    P = [[L1, L2,  L3,  L4],
         [L5, L6,  L7,  L8],
         [L9, L10, L11, 1 ]]            (a34 = 1 implied)

The tools differ on where the vertical pixel axis starts; `flip_v_height=H` converts between our
top-left origin (v down) and a bottom-left one (v' = H - v, i.e. P' = F P with
F = [[1, 0, 0], [0, -1, H], [0, 0, 1]]).
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.dlt import MAX_CALIBRATION_NUMBER, CalibratedCamera
from wiithrow.vision.errors import CalibrationError, FileFormatError, FileTooLargeError
from wiithrow.vision.files import (
    CALIBRATION_SIZE,
    atomic_write_text,
    dump_strict,
    dumps_strict,
    non_finite_path,
    read_text,
    read_versioned_json,
)
from wiithrow.vision.outputs import OutputFiles
from wiithrow.vision.triangulation import Triangulation, triangulate

FILE_KIND = "wiithrow.calibration"
SCHEMA = 1


@dataclass(frozen=True)
class StereoCalibration:
    """C >= 2 calibrated cameras sharing one frame (`frame`, e.g. "link1"); `arm`: the arm whose
    link1 the frame is, when it is an arm's and known (module docstring; default: `meta["arm"]`)."""

    cameras: tuple[CalibratedCamera, ...]
    frame: str = "link1"
    loo_error_m: float | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    arm: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "cameras", tuple(self.cameras))
        if self.arm is None and isinstance(self.meta.get("arm"), str) and self.meta["arm"]:
            object.__setattr__(self, "arm", self.meta["arm"])
        if len(self.cameras) < 2:
            raise CalibrationError(f"a rig needs at least 2 calibrated cameras, got {len(self.cameras)}")
        if self.loo_error_m is not None and not np.isfinite(self.loo_error_m):
            object.__setattr__(self, "loo_error_m", None)
        check_rig(self.Ps, [camera.name for camera in self.cameras])

    @property
    def Ps(self) -> NDArray[np.float64]:
        """The cameras' projection matrices, (C, 3, 4)."""
        return np.stack([camera.P for camera in self.cameras])

    @property
    def fingerprint(self) -> str:
        """16 hex digits that name this calibration wherever it is loaded (`calibration_fingerprint`
        of its projection matrices and frame): what a measurement records it was made with."""
        return calibration_fingerprint(self.Ps, self.frame)

    def triangulate(self, image: ArrayLike, *, refine: bool = False) -> Triangulation:
        """3D points in `frame` from pixels (C, N, 2), NaN where unseen (see wiithrow.vision.triangulation)."""
        return triangulate(self.Ps, image, refine=refine)

    # -- our own file --------------------------------------------------------------------------

    def _document(self) -> dict[str, Any]:
        return {
            "kind": FILE_KIND,
            "schema": SCHEMA,
            "frame": self.frame,
            "arm": self.arm,
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
            "loo_error_m": self.loo_error_m,
            "meta": self.meta,
            "cameras": [camera.to_dict() for camera in self.cameras],
        }

    def to_text(self) -> str:
        """The calibration as the text of its versioned JSON file."""
        return dumps_strict(self._document(), indent=2) + "\n"

    def write_json(self, handle: IO[str]) -> None:
        """Write the calibration's versioned JSON file to `handle` as it is encoded (a calibration
        of 100,000 points is 42 MB of text: it is never held whole). FileTooLargeError when the
        text is larger than a calibration file may be (`files.CALIBRATION_SIZE`): `load` would
        refuse it, so the write fails instead and the old file stays."""
        start = handle.tell()
        dump_strict(self._document(), handle, indent=2)
        handle.write("\n")
        size = handle.tell() - start
        if size > CALIBRATION_SIZE.max_bytes:
            points = max(len(camera.world) for camera in self.cameras)
            raise FileTooLargeError(
                f"a calibration of {points} points and {len(self.cameras)} cameras is {size / 1e6:.1f} MB, more than "
                f"a calibration file may be ({CALIBRATION_SIZE.max_bytes / 2**20:g} MiB: {CALIBRATION_SIZE.reason}): "
                "not written"
            )

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the calibration atomically as versioned JSON."""
        return OutputFiles().add(path, self.write_json).commit()[0]

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> StereoCalibration:
        """Read a calibration written by `save`; FileFormatError names the file on any problem, and
        the camera and the field for a bad value: every number must be finite (a NaN in K, rms_px
        or loo_error_m would otherwise be read without a word), `loo_error_m` >= 0 or null."""
        document = read_versioned_json(path, FILE_KIND, SCHEMA, CALIBRATION_SIZE)
        entries = document.get("cameras")
        if not isinstance(entries, list):
            raise FileFormatError(f"{path}: malformed calibration: 'cameras' must be a list, got {entries!r:.40}")
        cameras = []
        for i, entry in enumerate(entries):
            name = entry.get("name") if isinstance(entry, dict) else None
            label = f"camera {i}" + (f" ({name})" if isinstance(name, str) else "")
            # the arrays are checked by from_dict (with numpy), every other number here
            scalars = {k: v for k, v in entry.items() if k not in _CAMERA_ARRAYS} if isinstance(entry, dict) else {}
            where = non_finite_path(scalars)
            if where is not None:
                raise FileFormatError(f"{path}: {label}: {where} is {_NOT_FINITE}")
            try:
                cameras.append(CalibratedCamera.from_dict(entry))
            except CalibrationError as exc:
                raise FileFormatError(f"{path}: {label}: {exc}") from None
        rest = {key: value for key, value in document.items() if key != "cameras"}
        where = non_finite_path(rest)
        if where is not None:
            raise FileFormatError(f"{path}: {where} is {_NOT_FINITE}")
        frame = document.get("frame")
        if not isinstance(frame, str) or not frame:
            raise FileFormatError(f"{path}: malformed calibration: 'frame' must be a frame's name, got {frame!r:.40}")
        loo = document.get("loo_error_m")
        if loo is not None and (
            isinstance(loo, bool) or not isinstance(loo, int | float) or not 0 <= loo <= MAX_CALIBRATION_NUMBER
        ):
            raise FileFormatError(f"{path}: loo_error_m must be a distance >= 0 (m) or null, got {loo!r:.40}")
        meta = document.get("meta")
        if meta is not None and not isinstance(meta, dict):
            raise FileFormatError(f"{path}: malformed calibration: 'meta' must be an object, got {meta!r:.40}")
        arm = document.get("arm")
        if arm is not None and (not isinstance(arm, str) or not arm):
            raise FileFormatError(
                f"{path}: malformed calibration: 'arm' must be an arm's name or null, got {arm!r:.40}"
            )
        try:
            return cls(tuple(cameras), frame, None if loo is None else float(loo), dict(meta or {}), arm)
        except CalibrationError as exc:
            raise FileFormatError(f"{path}: {exc}") from None


def calibration_fingerprint(Ps: ArrayLike, frame: str) -> str:
    """16 hex digits of the SHA-256 of `frame` and the projection matrices `Ps` (C, 3, 4) as
    little-endian float64 bytes: the same calibration gives the same digits wherever it is loaded."""
    digest = hashlib.sha256(f"{frame}\0".encode())
    digest.update(np.ascontiguousarray(np.asarray(Ps, dtype=float), dtype="<f8").tobytes())
    return digest.hexdigest()[:16]


_CAMERA_ARRAYS = frozenset({"P", "K", "R", "t", "center", "world", "image", "residuals_px", "inliers"})
_NOT_FINITE = "NaN or infinite: every number in a calibration must be finite"

#: Camera centres closer than this (m) are one centre: two views from one point see no depth.
MIN_BASELINE_M = 1e-3
#: |det P[:, :3]| below this times ||P[:, :3]||^3 is a singular left block: no finite centre.
SINGULAR_RATIO = 1e-9


def check_rig(Ps: NDArray[np.float64], names: list[str]) -> None:
    """CalibrationError unless every P (C, 3, 4) is a finite camera (no entry beyond
    `MAX_CALIBRATION_NUMBER`) with a finite centre (its left
    3x3 block M regular, centre -M^-1 p4) and no two cameras share a centre (MIN_BASELINE_M)."""
    centres = []
    for P, name in zip(Ps, names):
        if not np.all(np.isfinite(P)):
            raise CalibrationError(f"{name}: its projection matrix is non-finite (NaN or inf)")
        if np.abs(P).max() > MAX_CALIBRATION_NUMBER:  # before any arithmetic: a norm of 1e308 overflows
            raise CalibrationError(
                f"{name}: its projection matrix has an entry of {np.abs(P).max():g}, beyond "
                f"{MAX_CALIBRATION_NUMBER:g} in magnitude: no camera's projection matrix has such an entry"
            )
        M = P[:, :3]
        scale = float(np.linalg.norm(M))
        if scale == 0 or abs(np.linalg.det(M)) <= SINGULAR_RATIO * scale**3:
            raise CalibrationError(
                f"{name}: its projection matrix is degenerate (its left 3x3 block is singular, so it has "
                "no camera centre): it is not a camera; calibrate again"
            )
        centres.append(-np.linalg.solve(M, P[:, 3]))
    for i in range(len(centres)):
        for j in range(i + 1, len(centres)):
            if np.linalg.norm(centres[i] - centres[j]) < MIN_BASELINE_M:
                raise CalibrationError(
                    f"{names[i]} and {names[j]} have the same centre ({', '.join(f'{v:.3f}' for v in centres[i])}) "
                    f"(closer than {1e3 * MIN_BASELINE_M:g} mm): two views from one point cannot triangulate; "
                    "was one camera's calibration copied to the other?"
                )


# -- the DLTdv / easyWand coefficient CSV -------------------------------------------------------


def _flip(height: float) -> NDArray[np.float64]:
    return np.array([[1.0, 0.0, 0.0], [0.0, -1.0, height], [0.0, 0.0, 1.0]])


def save_dlt_coefficients(path: str | os.PathLike[str], Ps: ArrayLike, *, flip_v_height: float | None = None) -> Path:
    """Write projection matrices (C, 3, 4) as the 11-coefficient DLT CSV (atomically)."""
    return atomic_write_text(path, dlt_coefficients_text(Ps, flip_v_height=flip_v_height))


def dlt_coefficients_text(Ps: ArrayLike, *, flip_v_height: float | None = None) -> str:
    """Projection matrices (C, 3, 4) as the text of the 11-coefficient DLT CSV; FileFormatError
    when a camera has p34 = 0 (the world origin in its focal plane)."""
    P = np.asarray(Ps, dtype=float).reshape(-1, 3, 4)
    columns = []
    for c, Pc in enumerate(P):
        if flip_v_height is not None:
            Pc = _flip(flip_v_height) @ Pc
        if abs(Pc[2, 3]) < 1e-12 * np.abs(Pc).max():
            raise FileFormatError(
                f"camera {c}: p34 is 0 (the world origin lies in its focal plane), so it cannot be "
                "written as 11 DLT coefficients with a34 = 1; move the world origin"
            )
        columns.append((Pc / Pc[2, 3]).ravel()[:11])
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    for row in np.array(columns).T:
        writer.writerow([repr(float(v)) for v in row])
    return text.getvalue()


def load_dlt_coefficients(path: str | os.PathLike[str], *, flip_v_height: float | None = None) -> NDArray[np.float64]:
    """Read an 11-coefficient DLT CSV: projection matrices (C, 3, 4) with p34 = 1."""
    path = Path(path)
    lines = [line for line in read_text(path).splitlines() if line.strip()]
    try:
        rows = [[float(value) for value in line.split(",")] for line in lines]
    except ValueError as exc:
        raise FileFormatError(f"{path}: not a DLT coefficient CSV ({exc})") from None
    if len(rows) != 11 or len({len(r) for r in rows}) != 1:
        raise FileFormatError(
            f"{path}: a DLT coefficient file has 11 rows with one column per camera; found "
            f"{len(rows)} rows with {sorted({len(r) for r in rows})} columns"
        )
    L = np.array(rows)  # (11, C)
    if not np.all(np.isfinite(L)):
        raise FileFormatError(f"{path}: contains NaN or inf coefficients")
    Ps = np.concatenate([L.T, np.ones((L.shape[1], 1))], axis=1).reshape(-1, 3, 4)
    if flip_v_height is not None:
        F_inv = np.linalg.inv(_flip(flip_v_height))
        Ps = np.stack([F_inv @ P for P in Ps])
    return Ps
