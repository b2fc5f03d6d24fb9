"""The arm's kinematic errors identified together with the cameras: the robot calibration's refinement.

The robot-driven calibration takes the LED's position from forward kinematics (FK) of the measured
joints. No arm is built exactly as its model says: a joint's zero is off by a few mrad, a joint's
origin by a millimetre or so, the LED sits a little off where the hand's drawing puts it. The FK's
points are then wrong by a few mm in a way that changes from pose to pose; the DLT fits them as
well as it can, and the error grows when the rig measures beyond the calibrated volume (the
throwing area lies 1.0-1.6 m from the joint-1 axis, beyond the reach of the arm that calibrated
it). So the calibration identifies a small set of kinematic corrections k together with the
cameras, by minimising the reprojection error of every measured dot (a bundle adjustment whose
3D points are tied to the arm's joints):

    min over (theta_1..theta_C, k) of  sum_c sum_i || x_ci - pi(P_c(theta_c), X(q_i, k)) ||^2

with P_c = K [R | -R C] over its 11 degrees of freedom (`vision.dlt_solvers.compose_camera`) and
X(q, k) the marker in `link1` by the nominal model (Pinocchio, `robot.ArmModel`) with k applied.

The corrections (`candidate_parameters`), for every joint j after the second:

* its zero offset d_j: the link stands at q_j + d_j;       dX/dd_j = w_j x (X - o_j)
  (w_j, o_j the joint's axis and origin: the column of the marker's Jacobian);
* its origin's offset e_j in the parent link's frame;         dX/de_j = R_parent(q)
* and the LED's offset f in the flange frame;                 dX/df = R_flange(q),

all rotated into link1 by R_1^T. Joints 1 and 2 are the gauge: the rig is fixed in link1, so a
change of joint 1 or of joint 2's origin or zero moves every calibration point by the same rigid
motion in link1, which the cameras absorb (joint 1's offset is link1's own frame; the throw plane's
distance and height do not change with it). They stay nominal: the calibration's frame is link1 as
the nominal model places it. A common scale of the link lengths is a scale of the cameras' world
too: the identifiability test below drops one length for it.

Identifiability: with the cameras free, not every correction is seen by the data (a joint's origin
offset along the previous joint's axis is a length change of that link twice over; the zero of the
last joint moves nothing while the LED sits on its axis; ...). `observable` decides it from the
data: the corrections' Jacobian columns, scaled by the tolerance each is expected to have
(`TOLERANCE_M`, `TOLERANCE_RAD`) and with the cameras' columns projected out (the Schur
complement: what the cameras cannot mimic), go through a column-pivoted QR; a correction is kept
while its pivot |R_kk| is at least `MIN_PIVOT` of the first one, i.e. the reduced problem's
condition number stays below 1 / MIN_PIVOT. The kept set is minimal (no two columns explain the
same motion) and well-conditioned; the others stay zero. Their number, the condition number and the
dropped names go into the calibration's meta.

A prior of one tolerance per kept correction (residual sigma k / tolerance, sigma the first fit's
own pixel noise) keeps combinations the data see weakly from chasing noise. The corrections are
used only when they predict poses the fit has not seen better than the nominal kinematics: a
`CV_FOLDS`-fold cross-validation of the reprojection error, the identified RMS below `CV_MARGIN`
of the nominal one (an exact arm keeps its nominal kinematics).

The result gives the corrected marker positions in link1 for the measured poses; the cameras are
then fitted to those as before (`points.calibrate_rig`: for fixed points, each camera's refined DLT
is the joint optimum's camera part), with the cross-validation and the checks of every calibration.

Only the camera fit uses the corrections: the rig measures targets in link1, which depends on
joint 1 alone (nominal), and the planner keeps the nominal model (the learning absorbs its errors).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray
from scipy.linalg import qr
from scipy.optimize import least_squares

from wiithrow.app.errors import AppError
from wiithrow.robot import ArmModel
from wiithrow.vision import calibrate
from wiithrow.vision.dlt_solvers import compose_camera, compose_jacobian
from wiithrow.vision.geometry import decompose, homogeneous, project

#: How the robot calibration treats the arm's kinematics: "identified" (corrections found with the
#: cameras, this module) or "nominal" (the FK of the nominal model taken as exact: the paper's).
Kinematics = Literal["identified", "nominal"]
KINEMATICS: tuple[Kinematics, ...] = ("identified", "nominal")

#: The tolerances the corrections are scaled by in the identifiability test and the prior (a joint
#: origin's placement, a joint's zero): what a machined and assembled arm typically has.
TOLERANCE_M = 1e-3
TOLERANCE_RAD = 2e-3
#: A correction is kept while its pivot is at least this share of the largest (condition <= 1/MIN_PIVOT).
MIN_PIVOT = 0.001
#: Folds of the cross-validation that decides whether the corrections are used.
CV_FOLDS = 5
#: ... and by how much they must predict better: a held-out RMS below this share of the nominal one.
CV_MARGIN = 0.9
#: The first joint whose corrections are identified (0-based): joints 1 and 2 are the gauge.
FIRST_IDENTIFIED_JOINT = 2


@dataclass(frozen=True)
class Correction:
    """One kinematic correction: `kind` "offset" (a joint's zero, rad), "origin" (a joint origin's
    offset along `axis` of the parent link's frame, m) or "led" (the LED's offset along `axis` of
    the flange frame, m); `joint` the Pinocchio joint index (1 = joint 1) for the first two."""

    kind: Literal["offset", "origin", "led"]
    joint: int
    axis: int
    name: str

    @property
    def tolerance(self) -> float:
        return TOLERANCE_RAD if self.kind == "offset" else TOLERANCE_M


def candidate_parameters(arm: ArmModel) -> list[Correction]:
    """Every correction this module can identify on `arm` (module docstring), in a fixed order."""
    out: list[Correction] = []
    names = arm.joint_names
    marker_joint = arm.model.frames[arm.frame_id("marker")].parentJoint
    for j in range(FIRST_IDENTIFIED_JOINT + 1, marker_joint + 1):
        name = names[j - 1]
        out.append(Correction("offset", j, -1, f"{name} zero offset"))
        parent = arm.model.names[arm.model.parents[j]]
        out += [Correction("origin", j, a, f"{name} origin {'xyz'[a]} (in {parent})") for a in range(3)]
    out += [Correction("led", marker_joint, a, f"LED {'xyz'[a]} (in the flange)") for a in range(3)]
    return out


class CorrectedKinematics:
    """The marker's position in link1 and its derivatives, on the nominal model with corrections."""

    def __init__(self, arm: ArmModel, parameters: Sequence[Correction]) -> None:
        self.arm = arm
        self.parameters = list(parameters)
        self.nominal = arm.model
        self.model = pin.Model(arm.model)
        self.data = self.model.createData()
        marker = arm.model.frames[arm.frame_id("marker")]
        link1 = arm.model.frames[arm.frame_id("link1")]
        self.marker_joint, self.marker_placement = marker.parentJoint, marker.placement
        self.link1_joint, self.link1_placement = link1.parentJoint, link1.placement
        self.axes = {j: self._joint_axis(j) for j in range(1, self.model.njoints)}

    def _joint_axis(self, j: int) -> NDArray[np.float64]:
        """The joint's axis in its own frame (a revolute joint: the motion subspace's angular part)."""
        S = self.nominal.joints[j].shortname()
        axes = {"JointModelRX": (1.0, 0, 0), "JointModelRY": (0, 1.0, 0), "JointModelRZ": (0, 0, 1.0)}
        if S in axes:
            return np.array(axes[S])
        if S == "JointModelRevoluteUnaligned":
            return np.asarray(self.nominal.joints[j].extract().axis, dtype=float)
        raise AppError(f"arm {self.arm.name!r}: joint {j} is a {S}, the kinematic identification needs revolute joints")

    def apply(self, k: NDArray[np.float64]) -> None:
        """Set the corrections `k` (one value per parameter) on the model."""
        for j in range(1, self.model.njoints):
            self.model.jointPlacements[j] = self.nominal.jointPlacements[j]
        self.led = np.zeros(3)
        offsets: dict[int, float] = {}
        origins: dict[int, NDArray[np.float64]] = {}
        for p, value in zip(self.parameters, k):
            if p.kind == "offset":
                offsets[p.joint] = offsets.get(p.joint, 0.0) + float(value)
            elif p.kind == "origin":
                origins.setdefault(p.joint, np.zeros(3))[p.axis] += float(value)
            else:
                self.led[p.axis] += float(value)
        for j in set(offsets) | set(origins):
            M = self.nominal.jointPlacements[j]
            R = M.rotation @ pin.exp3(self.axes[j] * offsets.get(j, 0.0))
            self.model.jointPlacements[j] = pin.SE3(R, M.translation + origins.get(j, np.zeros(3)))

    def marker(
        self, q: NDArray[np.float64], *, jacobian: bool = True
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """X (3,) in link1 at q with the corrections last `apply`'d, and dX/dk (3, K)."""
        pin.forwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        oMi = self.data.oMi
        T1 = oMi[self.link1_joint] * self.link1_placement
        R1t, o1 = T1.rotation.T, T1.translation
        Tm = oMi[self.marker_joint] * self.marker_placement
        p_base = Tm.translation + Tm.rotation @ self.led
        X = R1t @ (p_base - o1)
        if not jacobian:
            return X, np.zeros((3, 0))
        J = np.empty((3, len(self.parameters)))
        for n, p in enumerate(self.parameters):
            if p.kind == "offset":
                w = oMi[p.joint].rotation @ self.axes[p.joint]
                J[:, n] = R1t @ np.cross(w, p_base - oMi[p.joint].translation)
            elif p.kind == "origin":
                J[:, n] = R1t @ oMi[int(self.model.parents[p.joint])].rotation[:, p.axis]
            else:
                J[:, n] = R1t @ Tm.rotation[:, p.axis]
        return X, J

    def markers(self, Q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """X (N, 3) and dX/dk (N, 3, K) for joint states Q (N, nq)."""
        out = [self.marker(q) for q in Q]
        return np.array([x for x, _ in out]), np.array([j for _, j in out])


@dataclass(frozen=True)
class KinematicIdentification:
    """The identified corrections and what the identification saw.

    `parameters`/`values`: the kept corrections and their values (rad or m); `dropped`: the names
    of those the data could not tell apart from the cameras or from each other; `condition`: the
    kept set's condition number (tolerance-scaled, cameras projected out); `rms_px_before` and
    `rms_px_after`: the reprojection RMS of the joint fit with the nominal and the corrected
    kinematics; `held_out_px`: the cross-validated reprojection RMS of held-out poses, nominal and
    identified (`cross_validate`); `used`: whether the corrections are applied (they predict held-out
    poses better); `positions`: the marker positions (N, 3) in link1 the cameras are fitted to
    (corrected when `used`)."""

    parameters: list[Correction]
    values: NDArray[np.float64]
    dropped: list[str]
    condition: float
    rms_px_before: float
    rms_px_after: float
    held_out_px: dict[str, float]
    used: bool
    positions: NDArray[np.float64] = field(repr=False)

    def to_meta(self) -> dict[str, Any]:
        """JSON-ready for the calibration's meta (corrections in mrad for zero offsets, mm for
        origins and the LED)."""
        return {
            "kinematics": "identified" if self.used else "nominal",
            "why": (
                "the identified kinematics predict held-out poses better"
                if self.used
                else "the identified kinematics do not predict held-out poses better than the nominal ones"
            ),
            "corrections": {p.name: 1e3 * float(v) for p, v in zip(self.parameters, self.values)},
            "correction_units": "mrad (zero offsets), mm (origins, LED)",
            "not_observable": self.dropped,
            "condition": self.condition if np.isfinite(self.condition) else None,
            "joint_fit_rms_px": {"nominal": self.rms_px_before, "identified": self.rms_px_after},
            "held_out_rms_px": self.held_out_px,
        }


class _JointProblem:
    """Residuals and Jacobian of the joint fit over (theta_1..theta_C, k)."""

    def __init__(
        self,
        kinematics: CorrectedKinematics,
        Q: NDArray[np.float64],
        image: NDArray[np.float64],
        R0: list[NDArray[np.float64]],
    ) -> None:
        self.kin, self.Q, self.image, self.R0 = kinematics, Q, image, R0
        self.C = image.shape[0]
        self.seen: NDArray[np.bool_] = np.asarray(np.isfinite(image).all(axis=2))  # (C, N)
        self.K = len(kinematics.parameters)

    def split(self, x: NDArray[np.float64]) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
        return [x[11 * c : 11 * c + 11] for c in range(self.C)], x[11 * self.C :]

    def evaluate(
        self, x: NDArray[np.float64], *, jacobian: bool
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        thetas, k = self.split(x)
        self.kin.apply(k)
        X, dX = self.kin.markers(self.Q)
        Xh = homogeneous(X)
        rows, jac_rows = [], []
        for c in range(self.C):
            P = compose_camera(thetas[c], self.R0[c])
            s = self.seen[c]
            proj = Xh[s] @ P.T
            w = proj[:, 2:3]
            uv = proj[:, :2] / w
            rows.append((uv - self.image[c, s]).ravel())
            if not jacobian:
                continue
            n = int(s.sum())
            # d(u, v)/dP (chain rule of u = a / w, v = b / w; as `dlt_solvers.refine`)
            dP = np.zeros((n, 2, 12))
            dP[:, 0, 0:4] = Xh[s] / w
            dP[:, 0, 8:12] = -uv[:, 0:1] * Xh[s] / w
            dP[:, 1, 4:8] = Xh[s] / w
            dP[:, 1, 8:12] = -uv[:, 1:2] * Xh[s] / w
            J = np.zeros((2 * n, x.size))
            J[:, 11 * c : 11 * c + 11] = dP.reshape(-1, 12) @ compose_jacobian(thetas[c], self.R0[c])
            # d(u, v)/dX = (P[r, :3] - (u, v)_r P[2, :3]) / w, then dX/dk
            dX_img = (P[None, :2, :3] - uv[:, :, None] * P[None, 2:3, :3]) / w[:, :, None]  # (n, 2, 3)
            J[:, 11 * self.C :] = (dX_img @ dX[s]).reshape(2 * n, self.K)
            jac_rows.append(J)
        r = np.nan_to_num(np.concatenate(rows), nan=1e6)
        return r, (np.vstack(jac_rows) if jacobian else None)


def observable(
    J: NDArray[np.float64], n_camera: int, parameters: Sequence[Correction]
) -> tuple[NDArray[np.int64], float]:
    """Indices of the corrections the data determine (module docstring) and their condition number.

    `J`: the joint fit's Jacobian, the cameras' `n_camera` columns first, then one per correction."""
    Jc, Jk = J[:, :n_camera], J[:, n_camera:] * np.array([p.tolerance for p in parameters])
    U, s, _ = np.linalg.svd(Jc, full_matrices=False)
    U = U[:, s > 1e-10 * s[0]]
    reduced = Jk - U @ (U.T @ Jk)  # what the cameras cannot mimic
    _, R, pivots = qr(reduced, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    if diag.size == 0 or diag[0] == 0:
        return np.zeros(0, dtype=np.int64), float("nan")
    keep = int(np.sum(diag >= MIN_PIVOT * diag[0]))
    chosen = np.sort(pivots[:keep]).astype(np.int64)
    sv = np.linalg.svd(reduced[:, chosen], compute_uv=False)
    return chosen, float(sv[0] / sv[-1])


@dataclass(frozen=True)
class _Fit:
    parameters: list[Correction]
    values: NDArray[np.float64]
    dropped: list[str]
    condition: float
    rms_before: float
    rms_after: float
    Ps: NDArray[np.float64]  # (C, 3, 4) the joint fit's cameras
    nominal_Ps: NDArray[np.float64]  # (C, 3, 4) the cameras fitted to the nominal points


def _camera_parameters(P: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(theta, R0) of `compose_camera` for P: theta at the rotation R0 itself."""
    d = decompose(P)
    K = d.K
    return np.concatenate([[K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]], np.zeros(3), d.center]), d.R


def _fit(arm: ArmModel, Q: NDArray[np.float64], image: NDArray[np.float64]) -> _Fit:
    """The joint fit (module docstring) on poses Q (N, nq) and pixels (C, N, 2)."""
    candidates = candidate_parameters(arm)
    kin = CorrectedKinematics(arm, candidates)
    kin.apply(np.zeros(len(candidates)))
    X0, _ = kin.markers(Q)
    seen: NDArray[np.bool_] = np.asarray(np.isfinite(image).all(axis=2))
    nominal = np.stack(
        [calibrate(X0[seen[c]], image[c, seen[c]], "refined", name=f"cam{c}").P for c in range(image.shape[0])]
    )
    thetas, R0 = zip(*(_camera_parameters(P) for P in nominal))
    n_cam = 11 * len(nominal)
    r0, J0 = _JointProblem(kin, Q, image, list(R0)).evaluate(
        np.concatenate([*thetas, np.zeros(len(candidates))]), jacobian=True
    )
    assert J0 is not None
    chosen, condition = observable(J0, n_cam, candidates)
    kept = [candidates[i] for i in chosen]
    dropped = [p.name for i, p in enumerate(candidates) if i not in set(chosen.tolist())]
    problem = _JointProblem(CorrectedKinematics(arm, kept), Q, image, list(R0))
    tolerances = np.array([p.tolerance for p in kept])
    scale = np.concatenate([np.ones(n_cam), tolerances])

    def residuals(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return problem.evaluate(x, jacobian=False)[0]

    def jacobian(x: NDArray[np.float64]) -> NDArray[np.float64]:
        J = problem.evaluate(x, jacobian=True)[1]
        assert J is not None
        return J

    # first without the prior, for the measurements' own noise; then with it (module docstring)
    first = least_squares(
        residuals, np.concatenate([*thetas, np.zeros(len(kept))]), jac=jacobian, method="lm", x_scale=scale
    )
    sigma_px = float(np.sqrt(np.sum(first.fun**2) / max(first.fun.size - first.x.size, 1)))
    weight = sigma_px / tolerances

    def with_prior(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([residuals(x), weight * x[n_cam:]])

    def with_prior_jacobian(x: NDArray[np.float64]) -> NDArray[np.float64]:
        prior = np.zeros((len(kept), x.size))
        prior[:, n_cam:] = np.diag(weight)
        return np.vstack([jacobian(x), prior])

    result = least_squares(with_prior, first.x, jac=with_prior_jacobian, method="lm", x_scale=scale)
    fitted = result.fun[: first.fun.size]
    cams = np.stack([compose_camera(result.x[11 * c : 11 * c + 11], R0[c]) for c in range(len(nominal))])
    return _Fit(
        kept,
        result.x[n_cam:],
        dropped,
        condition,
        _rms(r0),
        _rms(fitted),
        cams,
        nominal,
    )


def _rms(residuals: NDArray[np.float64]) -> float:
    """RMS pixel error (px) of stacked (u, v) residuals."""
    r = residuals[np.isfinite(residuals)]
    return float(np.sqrt(2.0 * np.mean(r**2))) if r.size else float("nan")


def _reprojection(Ps: NDArray[np.float64], X: NDArray[np.float64], image: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([(project(P, X) - image[c]).ravel() for c, P in enumerate(Ps)])


def cross_validate(
    arm: ArmModel, Q: NDArray[np.float64], image: NDArray[np.float64], folds: int = CV_FOLDS
) -> dict[str, float]:
    """Held-out reprojection RMS (px) of the nominal and the identified kinematics: the poses are
    split into `folds` interleaved folds; each is predicted by cameras (and corrections) fitted
    to the others."""
    held: dict[str, list[NDArray[np.float64]]] = {"nominal": [], "identified": []}
    n = len(Q)
    for f in range(folds):
        test = np.arange(n) % folds == f
        fit = _fit(arm, Q[~test], image[:, ~test])
        kin = CorrectedKinematics(arm, fit.parameters)
        kin.apply(np.zeros(len(fit.parameters)))
        X0, _ = kin.markers(Q[test])
        kin.apply(fit.values)
        X1, _ = kin.markers(Q[test])
        held["nominal"].append(_reprojection(fit.nominal_Ps, X0, image[:, test]))
        held["identified"].append(_reprojection(fit.Ps, X1, image[:, test]))
    return {name: _rms(np.concatenate(r)) for name, r in held.items()}


def identify_kinematics(
    arm: ArmModel,
    q: NDArray[np.float64],
    image: NDArray[np.float64],
    positions: NDArray[np.float64] | None = None,
) -> KinematicIdentification:
    """Identify the corrections from the measured joints `q` (N, nq) and mean pixels `image`
    (C, N, 2, NaN where a camera missed the LED); see the module docstring. They are used only
    when they predict held-out poses better than the nominal kinematics (`cross_validate`).

    `positions` (N, 3): the nominal FK positions the calibration measured (averaged over each
    pose's joint samples); the corrected ones are these plus the corrections' displacement at the
    pose's mean joints (default: the nominal FK at `q`)."""
    Q = np.asarray(q, dtype=float)
    fit = _fit(arm, Q, image)
    held = cross_validate(arm, Q, image)
    used = held["identified"] < CV_MARGIN * held["nominal"]
    kin = CorrectedKinematics(arm, fit.parameters)
    kin.apply(np.zeros(len(fit.parameters)))
    X0, _ = kin.markers(Q)
    kin.apply(fit.values)
    X1, _ = kin.markers(Q)
    base = X0 if positions is None else np.asarray(positions, dtype=float)
    return KinematicIdentification(
        fit.parameters,
        fit.values,
        fit.dropped,
        fit.condition,
        fit.rms_before,
        fit.rms_after,
        held,
        bool(used),
        base + (X1 - X0) if used else base,
    )
