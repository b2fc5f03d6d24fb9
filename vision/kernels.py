"""Compiled kernels (numba): projection, triangulation, correspondence, tracks and interpolation.

Why compiled: a tracking frame holds at most four dots per camera, and at that size numpy's fixed
cost per call (1-5 us) makes a frame cost hundreds of microseconds; the same arithmetic compiled
costs about one. For large batches the compiled loop is also several times faster than array
arithmetic (no temporaries). Every kernel is a plain loop over points that a reader can check
against the equation next to it; `cache=True` keeps the compiled code between runs.

Why one module: numba's on-disk cache is invalidated per source file. A cached kernel that calls a
kernel of another file keeps the machine code compiled from the callee's old source after that
file changes (numba's caching notes: "cache invalidation fails to recognize changes in symbols
defined in a different file"). The kernels call each other in a chain (`track_predicted` ->
`match_predicted` -> `triangulate_groups` -> `project_point`), so they stay together here, in
sections by the module they serve.

Conventions: projection matrices P (C, 3, 4) are pre-scaled so that ||P[c, 2, :3]|| = 1 (then the
linear rows of every camera weigh alike, and (P X~)_3 is the depth); pixels (C, N, 2) hold NaN for
a missing observation. `project_point` is the projection of `wiithrow.vision.geometry` (eq. 15)
for one point and camera; every kernel projects through it.

Linear triangulation (the paper's eq. 11-13). Each camera that sees the point adds two rows

    a = u p3 - p1,   a' = v p3 - p2,      with  a . [X; 1] = 0,

so X solves the 3x3 normal equations H X = g with H = sum a[:3] a[:3]^T and g = -sum a[:3] a[3];
H is symmetric, solved by its adjugate: X = adj(H) g / det(H).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

#: |det(H)| below this times trace(H)^3 is a degenerate geometry (e.g. a point on the baseline).
SINGULAR_RATIO = 1e-12

Floats = NDArray[np.float64]
Ints = NDArray[np.int64]
Bools = NDArray[np.bool_]

# --------------------------------------------------------------------------------------------
# Projection and triangulation (wiithrow.vision.triangulation, and the kernels below)


# Not inlined at numba's level (LLVM inlines it anyway): numba-IR inlining here made the
# Gauss-Newton refinement a third slower (bench triangulate: 3.4 -> 2.3 M points/s).
@njit(cache=True)
def project_point(P: Floats, c: int, X0: float, X1: float, X2: float) -> tuple[float, float, float]:
    """Camera c's pixel (u, v) of the point X and w = (P X~)_3: (a, b, w) = P_c [X; 1], u = a / w,
    v = b / w. u = v = NaN where w = 0 (the point has no image)."""
    w = P[c, 2, 0] * X0 + P[c, 2, 1] * X1 + P[c, 2, 2] * X2 + P[c, 2, 3]
    if w == 0.0:
        return np.nan, np.nan, w
    u = (P[c, 0, 0] * X0 + P[c, 0, 1] * X1 + P[c, 0, 2] * X2 + P[c, 0, 3]) / w
    v = (P[c, 1, 0] * X0 + P[c, 1, 1] * X1 + P[c, 1, 2] * X2 + P[c, 1, 3]) / w
    return u, v, w


@njit(cache=True, inline="always")
def _add_row(H: Floats, g: Floats, a0: float, a1: float, a2: float, b: float) -> None:
    """Normal equations of one row a . X = -b: H += a a^T (h00, h01, h02, h11, h12, h22), g -= a b."""
    H[0] += a0 * a0
    H[1] += a0 * a1
    H[2] += a0 * a2
    H[3] += a1 * a1
    H[4] += a1 * a2
    H[5] += a2 * a2
    g[0] -= a0 * b
    g[1] -= a1 * b
    g[2] -= a2 * b


@njit(cache=True, inline="always")
def _accumulate(P: Floats, c: int, u: float, v: float, H: Floats, g: Floats) -> None:
    """Add camera c's two linear rows for pixel (u, v): (u p3 - p1) and (v p3 - p2)."""
    for r in range(2):
        w = u if r == 0 else v
        _add_row(
            H,
            g,
            w * P[c, 2, 0] - P[c, r, 0],
            w * P[c, 2, 1] - P[c, r, 1],
            w * P[c, 2, 2] - P[c, r, 2],
            w * P[c, 2, 3] - P[c, r, 3],
        )


@njit(cache=True)
def _set_nan(out: Floats, n: int) -> None:
    """out[n] = (NaN, NaN, NaN): a point that could not be triangulated."""
    out[n, 0] = np.nan
    out[n, 1] = np.nan
    out[n, 2] = np.nan


@njit(cache=True, inline="always")
def _solve3(H: Floats, g: Floats, out: Floats, n: int) -> bool:
    """out[n] = H^-1 g for symmetric H by the adjugate; NaN when H is singular. Returns success."""
    h00, h01, h02, h11, h12, h22 = H[0], H[1], H[2], H[3], H[4], H[5]
    c00 = h11 * h22 - h12 * h12
    c01 = h02 * h12 - h01 * h22
    c02 = h01 * h12 - h02 * h11
    c11 = h00 * h22 - h02 * h02
    c12 = h01 * h02 - h00 * h12
    c22 = h00 * h11 - h01 * h01
    det = h00 * c00 + h01 * c01 + h02 * c02
    trace = h00 + h11 + h22
    if not abs(det) > SINGULAR_RATIO * trace * trace * trace:
        _set_nan(out, n)
        return False
    out[n, 0] = (c00 * g[0] + c01 * g[1] + c02 * g[2]) / det
    out[n, 1] = (c01 * g[0] + c11 * g[1] + c12 * g[2]) / det
    out[n, 2] = (c02 * g[0] + c12 * g[1] + c22 * g[2]) / det
    return True


@njit(cache=True)
def triangulate_linear(P: Floats, x: Floats, out: Floats, views: Ints) -> None:
    """Linear triangulation of every point: x (C, N, 2) -> out (N, 3), views (N,) counts.
    Points seen by fewer than two cameras are NaN."""
    C, N = x.shape[0], x.shape[1]
    H = np.empty(6)
    g = np.empty(3)
    for n in range(N):
        H[:] = 0.0
        g[:] = 0.0
        seen = 0
        for c in range(C):
            u = x[c, n, 0]
            v = x[c, n, 1]
            if u != u or v != v:
                continue
            seen += 1
            _accumulate(P, c, u, v, H, g)
        views[n] = seen
        if seen < 2:
            _set_nan(out, n)
        else:
            _solve3(H, g, out, n)


# The loop of `triangulate_linear` again, with each point's own cameras: sharing one helper
# between the two halved `triangulate_linear`'s speed (bench triangulate --quick: 26 -> 13 M
# points/s with the helper inlined or not), and it is the hot path of tracking and triangulation.
@njit(cache=True)
def triangulate_each(P: Floats, x: Floats, out: Floats, views: Ints) -> None:
    """`triangulate_linear` with cameras of each point's own: P (N, C, 3, 4), point n seen
    through P[n] (leave-one-out: the cameras refitted without point n). A camera whose P[n] is
    NaN does not count; NaN where fewer than two cameras saw the point."""
    C, N = x.shape[0], x.shape[1]
    H = np.empty(6)
    g = np.empty(3)
    for n in range(N):
        H[:] = 0.0
        g[:] = 0.0
        seen = 0
        for c in range(C):
            u = x[c, n, 0]
            v = x[c, n, 1]
            if u != u or v != v or P[n, c, 2, 3] != P[n, c, 2, 3]:
                continue
            seen += 1
            _accumulate(P[n], c, u, v, H, g)
        views[n] = seen
        if seen < 2:
            _set_nan(out, n)
        else:
            _solve3(H, g, out, n)


@njit(cache=True)
def gauss_newton(P: Floats, x: Floats, X: Floats, iterations: int) -> None:
    """Refine X (N, 3) in place by Gauss-Newton on sum_c ||(u, v)_c - pi(P_c, X)||^2.

    With (a, b, w) = P_c [X; 1] and u^ = a / w the Jacobian rows are (p1 - u^ p3) / w and
    (p2 - v^ p3) / w: the linear rows divided by the depth, so each step is the linear solve
    re-weighted by 1/depth and linearised at the current estimate.
    """
    C, N = x.shape[0], x.shape[1]
    H = np.empty(6)
    g = np.empty(3)
    step = np.empty((1, 3))
    for n in range(N):
        if X[n, 0] != X[n, 0]:
            continue
        for _ in range(iterations):
            H[:] = 0.0
            g[:] = 0.0
            for c in range(C):
                u = x[c, n, 0]
                v = x[c, n, 1]
                if u != u or v != v:
                    continue
                uh, vh, w = project_point(P, c, X[n, 0], X[n, 1], X[n, 2])
                if w == 0.0:
                    continue
                for r in range(2):
                    res = (uh - u) if r == 0 else (vh - v)
                    est = uh if r == 0 else vh
                    _add_row(
                        H,
                        g,
                        (P[c, r, 0] - est * P[c, 2, 0]) / w,
                        (P[c, r, 1] - est * P[c, 2, 1]) / w,
                        (P[c, r, 2] - est * P[c, 2, 2]) / w,
                        res,
                    )
            if not _solve3(H, g, step, 0):
                break
            X[n, 0] += step[0, 0]
            X[n, 1] += step[0, 1]
            X[n, 2] += step[0, 2]


@njit(cache=True, inline="always")
def _reprojection(P: Floats, c: int, X0: float, X1: float, X2: float, u: float, v: float) -> float:
    """Pixel distance between (u, v) and the projection of X in camera c (inf where X has no image)."""
    uh, vh, w = project_point(P, c, X0, X1, X2)
    if w == 0.0:
        return np.inf
    du = uh - u
    dv = vh - v
    return float(np.sqrt(du * du + dv * dv))


@njit(cache=True)
def reprojection_rms(P: Floats, x: Floats, X: Floats, out: Floats) -> None:
    """RMS over the cameras that saw each point of its reprojection error: out (N,) pixels."""
    C, N = x.shape[0], x.shape[1]
    for n in range(N):
        total = 0.0
        seen = 0
        for c in range(C):
            u = x[c, n, 0]
            v = x[c, n, 1]
            if u != u or v != v:
                continue
            e = _reprojection(P, c, X[n, 0], X[n, 1], X[n, 2], u, v)
            total += e * e
            seen += 1
        out[n] = np.sqrt(total / seen) if seen > 0 and X[n, 0] == X[n, 0] else np.nan


@njit(cache=True)
def project(P: Floats, X: Floats, out: Floats) -> None:
    """Pixels out (C, N, 2) of points X (N, 3) in every camera; NaN where a point has no image."""
    for c in range(P.shape[0]):
        for n in range(X.shape[0]):
            out[c, n, 0], out[c, n, 1], _ = project_point(P, c, X[n, 0], X[n, 1], X[n, 2])


@njit(cache=True)
def triangulate_groups(P: Floats, x: Floats, slots: Ints, points: Floats, errors: Floats) -> None:
    """Triangulate candidate markers. slots (G, C): the dot index used in each camera (-1: none);
    points (G, 3) out; errors (G, C) out: each used camera's reprojection error, -1 if unused."""
    G, C = slots.shape
    H = np.empty(6)
    g = np.empty(3)
    for m in range(G):
        H[:] = 0.0
        g[:] = 0.0
        seen = 0
        for c in range(C):
            k = slots[m, c]
            if k >= 0:
                seen += 1
                _accumulate(P, c, x[c, k, 0], x[c, k, 1], H, g)
        ok = seen >= 2 and _solve3(H, g, points, m)
        if not ok:
            _set_nan(points, m)
        for c in range(C):
            k = slots[m, c]
            if k < 0:
                errors[m, c] = -1.0
            elif not ok:
                errors[m, c] = np.inf
            else:
                errors[m, c] = _reprojection(P, c, points[m, 0], points[m, 1], points[m, 2], x[c, k, 0], x[c, k, 1])


# --------------------------------------------------------------------------------------------
# Correspondence: which dots make which marker (wiithrow.vision.correspondence)


@njit(cache=True)
def assign_to_predictions(P: Floats, x: Floats, predicted: Floats, gate: float, slots: Ints) -> int:
    """Assign each camera's dots to the projections of predicted markers.

    slots (M, C) out: the dot index per prediction and camera (-1: none). Per camera, if every
    prediction's nearest free dot is within `gate` pixels and no two predictions share it, that is
    the minimum-cost assignment (it reaches the lower bound sum of row minima) and is written;
    predictions with no dot within the gate get -1. Returns a bitmask of the cameras where the
    nearest dots conflict, for which the caller runs the full assignment.
    """
    M, C, K = predicted.shape[0], x.shape[0], x.shape[1]
    ambiguous = 0
    best = np.empty(M, dtype=np.int64)
    for c in range(C):
        for m in range(M):
            best[m] = -1
            eu, ev, w = project_point(P, c, predicted[m, 0], predicted[m, 1], predicted[m, 2])
            if w == 0.0:
                continue
            nearest = gate
            for k in range(K):
                u = x[c, k, 0]
                if u != u:
                    continue
                d = np.sqrt((u - eu) ** 2 + (x[c, k, 1] - ev) ** 2)
                if d < nearest:
                    nearest = d
                    best[m] = k
        conflict = False
        for m in range(M):
            for m2 in range(m + 1, M):
                if best[m] >= 0 and best[m] == best[m2]:
                    conflict = True
        if conflict:
            ambiguous |= 1 << c
        for m in range(M):
            slots[m, c] = -1 if conflict else best[m]
    return ambiguous


@njit(cache=True)
def accept_candidates(
    P: Floats, x: Floats, slots: Ints, gate: float, free: Bools, points: Floats, rms: Floats
) -> Bools:
    """Validate candidate markers in order; return which were accepted.

    slots (G, C) in/out: each candidate's dot per camera (-1: none); a candidate whose worst camera
    reprojects beyond `gate` pixels loses that camera while more than two remain. Accepted
    candidates must use free dots only; their dots are then marked used in `free` (C, K), their
    points (G, 3) and RMS reprojection errors (G,) written.
    """
    G, C = slots.shape
    accepted = np.zeros(G, dtype=np.bool_)
    one = np.empty((1, C), dtype=np.int64)
    point = np.empty((1, 3))
    errors = np.empty((1, C))
    for m in range(G):
        for c in range(C):
            one[0, c] = slots[m, c]
        while True:
            triangulate_groups(P, x, one, point, errors)
            if point[0, 0] != point[0, 0]:
                break
            worst = 0
            used = 0
            for c in range(C):
                if errors[0, c] > errors[0, worst]:
                    worst = c
                if one[0, c] >= 0:
                    used += 1
            if errors[0, worst] <= gate:
                available = True
                for c in range(C):
                    if one[0, c] >= 0 and not free[c, one[0, c]]:
                        available = False
                if available:
                    total = 0.0
                    for c in range(C):
                        if one[0, c] >= 0:
                            free[c, one[0, c]] = False
                            total += errors[0, c] * errors[0, c]
                        slots[m, c] = one[0, c]
                    points[m, 0] = point[0, 0]
                    points[m, 1] = point[0, 1]
                    points[m, 2] = point[0, 2]
                    rms[m] = np.sqrt(total / used)
                    accepted[m] = True
                break
            if used <= 2:
                break
            one[0, worst] = -1
    return accepted


@njit(cache=True)
def match_predicted(
    P: Floats,
    x: Floats,
    predicted: Floats,
    prediction_gate: float,
    gate: float,
    free: Bools,
    slots: Ints,
    points: Floats,
    rms: Floats,
    origins: Ints,
) -> int:
    """The common per-frame case in one pass: mark visible dots free, assign them to the predicted
    markers (`assign_to_predictions`), validate the candidates (`accept_candidates`) and compact
    the accepted ones to the front of slots/points/rms/origins.

    Returns the number of accepted markers, or -1 when some camera's assignment was ambiguous
    (nothing is written then; the caller runs the full assignment). free (C, K) is written.
    """
    C, K = x.shape[0], x.shape[1]
    for c in range(C):
        for k in range(K):
            free[c, k] = x[c, k, 0] == x[c, k, 0] and x[c, k, 1] == x[c, k, 1]
    M = predicted.shape[0]
    if M == 0:
        return 0
    candidates = np.empty((M, C), dtype=np.int64)
    if assign_to_predictions(P, x, predicted, prediction_gate, candidates) != 0:
        return -1
    keep = np.zeros(M, dtype=np.bool_)
    for m in range(M):
        seen = 0
        for c in range(C):
            if candidates[m, c] >= 0:
                seen += 1
        keep[m] = seen >= 2
    rows = np.flatnonzero(keep)
    group = candidates[rows]
    group_points = np.empty((rows.size, 3))
    group_rms = np.empty(rows.size)
    accepted = accept_candidates(P, x, group, gate, free, group_points, group_rms)
    n = 0
    for i in range(rows.size):
        if accepted[i]:
            slots[n] = group[i]
            points[n] = group_points[i]
            rms[n] = group_rms[i]
            origins[n] = rows[i]
            n += 1
    return n


# --------------------------------------------------------------------------------------------
# Interpolation of unsynchronised frames (wiithrow.vision.sync)


@njit(cache=True)
def interpolate_slots(
    t0: float, x0: Floats, t1: float, x1: Floats, t: float, jump_px: float, hold_s: float, out: Floats
) -> None:
    """Dots at time t between a camera's frames (t0, x0) and (t1, x1), slot by slot:
    x = x0 + (t - t0) / (t1 - t0) (x1 - x0); a slot empty on one side or jumping more than
    `jump_px` takes the nearer frame's dot if that frame is within `hold_s` of t, else NaN."""
    alpha = 0.0 if t1 == t0 else (t - t0) / (t1 - t0)
    near0 = (t - t0) <= (t1 - t)
    hold = min(t - t0, t1 - t) <= hold_s
    for k in range(x0.shape[0]):
        a_ok = x0[k, 0] == x0[k, 0]
        b_ok = x1[k, 0] == x1[k, 0]
        if a_ok and b_ok:
            du = x1[k, 0] - x0[k, 0]
            dv = x1[k, 1] - x0[k, 1]
            if du * du + dv * dv <= jump_px * jump_px:
                out[k, 0] = x0[k, 0] + alpha * du
                out[k, 1] = x0[k, 1] + alpha * dv
                continue
        src = x0 if near0 else x1
        if hold and src[k, 0] == src[k, 0]:
            out[k, 0] = src[k, 0]
            out[k, 1] = src[k, 1]
        else:
            out[k, 0] = np.nan
            out[k, 1] = np.nan


# --------------------------------------------------------------------------------------------
# Marker tracks: constant-velocity Kalman filters (wiithrow.vision.tracker)


@njit(cache=True)
def kf_predict(t: float, times: Floats, x: Floats, v: Floats, cov: Floats, q: float) -> None:
    """Constant-velocity prediction of every track to time t (per axis, shared 2x2 covariance):
    x <- x + dt v;  P <- F P F^T + q [[dt^3/3, dt^2/2], [dt^2/2, dt]]."""
    for i in range(x.shape[0]):
        dt = t - times[i]
        if dt <= 0.0:
            continue
        for a in range(3):
            x[i, a] += dt * v[i, a]
        p00, p01, p11 = cov[i, 0], cov[i, 1], cov[i, 2]
        cov[i, 0] = p00 + 2.0 * dt * p01 + dt * dt * p11 + q * dt * dt * dt / 3.0
        cov[i, 1] = p01 + dt * p11 + q * dt * dt / 2.0
        cov[i, 2] = p11 + q * dt
        times[i] = t


@njit(cache=True)
def kf_update(i: int, z: Floats, x: Floats, v: Floats, cov: Floats, r: float) -> None:
    """Kalman update of track i with a position measurement z (3,) of variance r:
    S = P00 + r, K = (P00, P01) / S, x <- x + K0 e, v <- v + K1 e, P <- (I - K H) P."""
    p00, p01, p11 = cov[i, 0], cov[i, 1], cov[i, 2]
    s = p00 + r
    k0 = p00 / s
    k1 = p01 / s
    for a in range(3):
        e = z[a] - x[i, a]
        x[i, a] += k0 * e
        v[i, a] += k1 * e
    cov[i, 0] = (1.0 - k0) * p00
    cov[i, 1] = (1.0 - k0) * p01
    cov[i, 2] = p11 - k1 * p01


@njit(cache=True)
def kf_distance2(i: int, z: Floats, x: Floats, cov: Floats, r: float) -> float:
    """Mahalanobis distance^2 of measurement z to track i: ||z - x||^2 / (P00 + r)."""
    d = 0.0
    for a in range(3):
        d += (z[a] - x[i, a]) ** 2
    return float(d / (cov[i, 0] + r))


@njit(cache=True)
def kf_hit(
    k: int,
    z: Floats,
    n_views: int,
    x: Floats,
    v: Floats,
    cov: Floats,
    r: float,
    measured: Floats,
    views: Ints,
    missed: Ints,
    hits: Ints,
    hit: Bools,
) -> None:
    """Track k measured at z (3,) by `n_views` cameras: its Kalman update (`kf_update`) and the
    bookkeeping of a hit (measured, views, missed = 0, hits + 1, hit)."""
    kf_update(k, z, x, v, cov, r)
    measured[k, 0] = z[0]
    measured[k, 1] = z[1]
    measured[k, 2] = z[2]
    views[k] = n_views
    missed[k] = 0
    hits[k] += 1
    hit[k] = True


@njit(cache=True)
def kf_absorb(
    origins: Ints,
    points: Floats,
    slots: Ints,
    x: Floats,
    v: Floats,
    cov: Floats,
    r: float,
    gate_chi2: float,
    measured: Floats,
    views: Ints,
    missed: Ints,
    hits: Ints,
    hit: Bools,
) -> Bools:
    """Update each track with the marker matched to its prediction, if within the 3D gate.

    origins (M,): the track each marker was matched to (-1: none); points (M, 3); slots (M, C).
    Writes the tracks' state and bookkeeping (measured, views, missed, hits, hit); returns the mask
    of markers left for association or birth.
    """
    M, C = slots.shape
    leftover = np.ones(M, dtype=np.bool_)
    for m in range(M):
        k = origins[m]
        if k < 0 or hit[k]:
            continue
        z = points[m]
        if kf_distance2(k, z, x, cov, r) > gate_chi2:
            continue
        n_views = 0
        for c in range(C):
            if slots[m, c] >= 0:
                n_views += 1
        kf_hit(k, z, n_views, x, v, cov, r, measured, views, missed, hits, hit)
        leftover[m] = False
    return leftover


#: `track_predicted` results.
TRACK_DONE, TRACK_AMBIGUOUS, TRACK_LEFTOVER = 0, 1, 2


@njit(cache=True)
def track_predicted(
    t: float,
    P: Floats,
    x: Floats,
    prediction_gate: float,
    gate: float,
    q: float,
    r: float,
    gate_chi2: float,
    n: int,
    times: Floats,
    pos: Floats,
    vel: Floats,
    cov: Floats,
    measured: Floats,
    views: Ints,
    missed: Ints,
    hits: Ints,
    hit: Bools,
    free: Bools,
    slots: Ints,
    points: Floats,
    rms: Floats,
    origins: Ints,
) -> tuple[int, int]:
    """The common tracking frame in one pass over the first n tracks: predict them to time t
    (`kf_predict`), match the dots to their predictions (`match_predicted`) and update each track
    with its marker (`kf_absorb`).

    Returns (status, m): TRACK_DONE when every marker updated its track and no camera pair has
    unused dots left; TRACK_AMBIGUOUS when the predicted assignment was ambiguous (only the
    prediction was done: the caller runs the full matching); TRACK_LEFTOVER when markers or dots
    are left for the caller (the m markers are in slots/points/rms/origins; those that updated no
    track have origins = -1; unused dots are marked in `free`).
    """
    kf_predict(t, times[:n], pos[:n], vel[:n], cov[:n], q)
    for i in range(n):
        _set_nan(measured, i)
        hit[i] = False
    m = match_predicted(P, x, pos[:n], prediction_gate, gate, free, slots, points, rms, origins)
    if m < 0:
        return TRACK_AMBIGUOUS, 0
    leftover = kf_absorb(
        origins[:m], points[:m], slots[:m], pos, vel, cov, r, gate_chi2, measured, views, missed, hits, hit
    )
    status = TRACK_DONE
    for i in range(m):
        if leftover[i]:
            origins[i] = -1
            status = TRACK_LEFTOVER
    cameras_with_free = 0
    for c in range(free.shape[0]):
        for k in range(free.shape[1]):
            if free[c, k]:
                cameras_with_free += 1
                break
    if cameras_with_free >= 2:
        status = TRACK_LEFTOVER
    return status, m


@njit(cache=True)
def kf_bookkeep(
    n: int,
    hit: Bools,
    hits: Ints,
    missed: Ints,
    confirmed: Bools,
    confirm_hits: int,
    max_missed: int,
) -> bool:
    """After a frame's updates: confirm tracks with `confirm_hits` hits; count a miss for the
    tracks not hit (a tentative track restarts its count). Returns True when some track has been
    missed too long (confirmed: more than `max_missed` frames, tentative: more than one) and must
    be removed by the caller."""
    remove = False
    for i in range(n):
        if hit[i]:
            if hits[i] >= confirm_hits:
                confirmed[i] = True
            continue
        missed[i] += 1
        if not confirmed[i]:
            hits[i] = 0
        if missed[i] > (max_missed if confirmed[i] else 1):
            remove = True
    return remove
