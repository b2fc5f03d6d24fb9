"""Temporal tracking of up to four 3D markers: stable ids across frames.

Every marker is a constant-velocity Kalman filter. Per axis the state is (position, velocity) and

    predict:  x <- F x,            P <- F P F^T + Q,    F = [[1, dt], [0, 1]],
              Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]     (white-noise acceleration, density q)
    update:   S = P_00 + r,        K = P[:, 0] / S,     x <- x + K (z - x_0),   P <- (I - K H) P

with H = [1, 0] and r the measurement variance of a triangulated position. The three axes share
one 2x2 covariance (isotropic noise), so a filter costs a handful of scalar operations.

A frame goes through four steps:
1. predict every track to the frame's time;
2. `Correspondence.match` with the tracks' predicted positions: each camera's dots are assigned to
   the predictions' projections first, which keeps ids through crossings and resolves epipolar
   ghosts; the rest is matched by epipolar geometry;
3. markers matched through a prediction update that track (if within the 3D gate: Mahalanobis
   d^2 = ||z - x||^2 / S below `gate_chi2`); the others are associated with the remaining tracks
   by minimum-cost assignment on d^2, gated;
4. unassociated markers start tentative tracks, confirmed after `confirm_hits` consecutive hits;
   a track not seen for more than `max_missed` frames dies (a hidden marker keeps its id meanwhile,
   coasting on its prediction).

A marker that stays keeps its id across longer dropouts too (an arm passing in front of it, a
target switched off during a calibration): a confirmed track that dies is remembered (its id and
where it was last seen, the `max_markers` most recent), and a new track born within
`reid_radius_m` of such a place takes that id back instead of a new one (the nearest, once);
and a marker that reappears where a still coasting track was last seen, outside its gate because
the prediction ran away on a noisy speed, restarts that track rather than a new one.
Without it a still target's id climbed by one per dropout longer than `max_missed` frames
(#5 to #33 in ten minutes of the demo). Ids stay unique among the live tracks: a remembered id
is never live (its track died), and it is forgotten once taken back.

Positions reported are the triangulated measurement when the marker was seen in this frame (no
lag from filtering), the prediction while it is hidden; the filtered state is reported as well.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision import kernels
from wiithrow.vision.correspondence import Correspondence, gated_assignment
from wiithrow.vision.errors import TriangulationError
from wiithrow.vision.tracked_frame import TrackedFrame, TrackedMarker

__all__ = ["MarkerTracker", "TrackedFrame", "TrackedMarker"]


#: A frozen dataclass's instance with no fields yet: `MarkerTracker.frame` sets them in one
#: dictionary update, where `TrackedFrame.__init__` calls `object.__setattr__` once per field
#: (a microsecond of every tracked frame; `test_tracker` compares the two).
_new = object.__new__

#: The working arrays of one `MarkerTracker.update` (`_scratch_for`).
_Scratch = tuple[
    NDArray[np.bool_], NDArray[np.bool_], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]
]


class MarkerTracker:
    """Tracks up to `max_markers` IR markers seen by C >= 2 calibrated cameras.

    Track state lives in arrays (one row per track) updated by compiled kernels, so a frame costs
    a few microseconds per marker (see `wiithrow bench tracking`).
    """

    def __init__(
        self,
        Ps: ArrayLike,
        *,
        max_markers: int = 4,
        accel_density: float = 400.0,
        measurement_sigma_m: float = 0.004,
        initial_speed_sigma: float = 3.0,
        gate_chi2: float = 25.0,
        confirm_hits: int = 2,
        max_missed: int = 25,
        reid_radius_m: float = 0.03,
        correspondence: Correspondence | None = None,
    ) -> None:
        self.correspondence = correspondence or Correspondence(Ps)
        self.max_markers = max_markers
        self.q = accel_density
        self.r = measurement_sigma_m**2
        self.initial_speed_var = initial_speed_sigma**2
        self.gate_chi2 = gate_chi2
        self.confirm_hits = confirm_hits
        self.max_missed = max_missed
        self.reid_radius_m = float(reid_radius_m)
        self._next_id = 0
        self._scratch: _Scratch | None = None
        self.reset()

    def reset(self) -> None:
        """Forget every track (ids keep counting up)."""
        n = self.max_markers
        self.count = 0  # live tracks are rows 0..count-1
        self.ids = np.zeros(n, dtype=np.int64)
        self.times = np.zeros(n)
        self.x = np.zeros((n, 3))  # filtered position
        self.v = np.zeros((n, 3))  # filtered velocity
        self.cov = np.zeros((n, 3))  # per-axis covariance (P00, P01, P11)
        self.hits = np.zeros(n, dtype=np.int64)
        self.missed = np.zeros(n, dtype=np.int64)
        self.confirmed = np.zeros(n, dtype=np.bool_)
        self.measured = np.full((n, 3), np.nan)  # this frame's triangulated position, NaN if unseen
        self.views = np.zeros(n, dtype=np.int64)
        self.last_seen = np.zeros((n, 3))  # the filtered position at the last hit
        self.known = np.zeros(n, dtype=np.bool_)  # carries an id taken back (remembered even if tentative)
        # confirmed tracks that died, most recent last: (id, where last seen), at most max_markers
        self._lost: list[tuple[int, NDArray[np.float64]]] = []
        self._reordered = False  # an id taken back: the rows must be put in id order again

    def update(self, t: float, dots: ArrayLike) -> TrackedFrame:
        """Process one synchronised frame: dots (C, K, 2) at time t; return the confirmed markers.

        The common frame (every dot matched through a prediction) runs in one compiled pass
        (`kernels.track_predicted`); ambiguous assignments, new markers and births take the
        Python paths below.
        """
        x = np.ascontiguousarray(dots, dtype=float)
        corr = self.correspondence
        if x.ndim != 3 or x.shape[0] != corr.cameras or x.shape[2] != 2:
            raise TriangulationError(f"dots must have shape ({corr.cameras}, K, 2), got {x.shape}")
        n = self.count
        hit, free, slots, points, rms, origins = self._scratch_for(x.shape[1])
        status, m = kernels.track_predicted(
            t,
            corr.Ps,
            x,
            corr.prediction_gate_px,
            corr.gate_px,
            self.q,
            self.r,
            self.gate_chi2,
            n,
            self.times,
            self.x,
            self.v,
            self.cov,
            self.measured,
            self.views,
            self.missed,
            self.hits,
            hit,
            free,
            slots,
            points,
            rms,
            origins,
        )
        if status == kernels.TRACK_AMBIGUOUS:  # predictions conflict in some camera: the full matching
            markers = corr.match(x, self.x[:n])
            leftover = kernels.kf_absorb(
                markers.predicted_index,
                markers.points,
                markers.slots,
                self.x,
                self.v,
                self.cov,
                self.r,
                self.gate_chi2,
                self.measured,
                self.views,
                self.missed,
                self.hits,
                hit,
            )
            self._associate_or_birth(t, markers.points[leftover], markers.slots[leftover], hit)
        elif status == kernels.TRACK_LEFTOVER:  # markers outside their track's gate, or unused dots
            unused = origins[:m] < 0
            new = corr.match_remaining(x, free)
            self._associate_or_birth(
                t, np.concatenate([points[:m][unused], new.points]), np.concatenate([slots[:m][unused], new.slots]), hit
            )
        n = self.count
        np.copyto(self.last_seen[:n], self.x[:n], where=hit[:n, None])
        if kernels.kf_bookkeep(n, hit, self.hits, self.missed, self.confirmed, self.confirm_hits, self.max_missed):
            self._remove_lost()
        if self._reordered:
            self._sort_by_id()
        return self.frame(t)

    def _scratch_for(self, slots_per_camera: int) -> _Scratch:
        """The arrays one `update` works in (hit, free, slots, points, rms, origins), made once
        per number of slots and reused: none of them outlives the update (what the Python paths
        keep of them are copies), and `hit` starts all False as `np.zeros` made it."""
        scratch = self._scratch
        if scratch is None or scratch[1].shape[1] != slots_per_camera:
            M, C = self.max_markers, self.correspondence.cameras
            scratch = self._scratch = (
                np.zeros(M, dtype=np.bool_),
                np.empty((C, slots_per_camera), dtype=np.bool_),
                np.empty((M, C), dtype=np.int64),
                np.empty((M, 3)),
                np.empty(M),
                np.empty(M, dtype=np.int64),
            )
        else:
            scratch[0].fill(False)
        return scratch

    def frame(self, t: float) -> TrackedFrame:
        """The confirmed tracks at time t, ordered by id (rows are kept in id order: births append
        with increasing ids, removals keep the order, and a frame in which a new track took an old
        id back ends by sorting the rows)."""
        n = self.count
        confirmed = self.confirmed[:n]
        # (np.count_nonzero: a C call, where ndarray.all() goes through numpy's Python reductions)
        rows = slice(0, n) if np.count_nonzero(confirmed) == n else np.flatnonzero(confirmed)
        position = self.measured[rows].copy()
        visible = position[:, 0] == position[:, 0]
        views = self.views[rows].copy()
        if np.count_nonzero(visible) < len(visible):
            hidden = ~visible
            position[hidden] = self.x[rows][hidden]
            views[hidden] = 0
        frame = _new(TrackedFrame)  # `TrackedFrame(t, ids, ...)`, its fields set at once (`_new`)
        frame.__dict__.update(
            t=t,
            ids=self.ids[rows].copy(),
            position=position,
            velocity=self.v[rows].copy(),
            filtered=self.x[rows].copy(),
            visible=visible,
            n_views=views,
        )
        return frame

    def markers(self, t: float) -> list[TrackedMarker]:
        """The confirmed markers at time t as objects."""
        return self.frame(t).markers()

    # -- internals ------------------------------------------------------------------------------

    def _associate_or_birth(
        self, t: float, points: NDArray[np.float64], slots: NDArray[np.int64], hit: NDArray[np.bool_]
    ) -> None:
        """Markers (points (L, 3), slots (L, C)) not matched through a prediction: associate them
        with the tracks not hit yet by minimum-cost assignment on the Mahalanobis distance (gated),
        else start new tracks."""
        if len(points) == 0:
            return
        free_tracks = np.flatnonzero(~hit[: self.count])
        born = np.ones(len(points), dtype=np.bool_)
        if free_tracks.size:
            cost = np.array(
                [[kernels.kf_distance2(int(k), z, self.x, self.cov, self.r) for z in points] for k in free_tracks]
            )
            for i, j in gated_assignment(cost, self.gate_chi2):
                k = int(free_tracks[i])
                n_views = int((slots[j] >= 0).sum())
                kernels.kf_hit(
                    k,
                    points[j],
                    n_views,
                    self.x,
                    self.v,
                    self.cov,
                    self.r,
                    self.measured,
                    self.views,
                    self.missed,
                    self.hits,
                    hit,
                )
                born[j] = False
        for new in np.flatnonzero(born):
            if self._reseat(points[new], int((slots[new] >= 0).sum()), hit):
                continue
            if self.count < self.max_markers:
                self._birth(t, points[new], int((slots[new] >= 0).sum()))
                hit[self.count - 1] = True

    def _remove_lost(self) -> None:
        """Drop the tracks missed too long (see `kernels.kf_bookkeep`), keeping the rows in order."""
        n = self.count
        limit = np.where(self.confirmed[:n], self.max_missed, 1)
        keep = self.missed[:n] <= limit
        for row in np.flatnonzero(~keep & (self.confirmed[:n] | self.known[:n])):  # its id may be taken back
            self._lost.append((int(self.ids[row]), self.last_seen[row].copy()))
        del self._lost[: -self.max_markers]
        self._keep_rows(np.flatnonzero(keep))

    def _sort_by_id(self) -> None:
        """Put the rows in id order again (after an id was taken back by a new track)."""
        self._keep_rows(np.argsort(self.ids[: self.count], kind="stable"))
        self._reordered = False

    def _keep_rows(self, rows: NDArray[np.int64]) -> None:
        """Rows 0..len(rows)-1 become the given rows, in that order; the others are dropped."""
        for array in (
            self.ids,
            self.times,
            self.x,
            self.v,
            self.cov,
            self.hits,
            self.missed,
            self.confirmed,
            self.measured,
            self.views,
            self.last_seen,
            self.known,
        ):
            array[: rows.size] = array[rows]
        self.count = rows.size

    def _reseat(self, z: NDArray[np.float64], n_views: int, hit: NDArray[np.bool_]) -> bool:
        """A marker outside every gate but within `reid_radius_m` of where a coasting track (not
        hit in this frame) was last seen is that track's marker come back: the track restarts
        there (position `z`, speed 0, as a birth) keeping its id. True if one did. (A coasting
        prediction runs away on the speed a few noisy hits before the dropout gave it.)"""
        n = self.count
        coasting = np.flatnonzero(~hit[:n] & (self.missed[:n] > 0))
        if coasting.size == 0:
            return False
        distances = np.linalg.norm(self.last_seen[coasting] - z, axis=1)
        k = int(coasting[np.argmin(distances)])
        if distances.min() > self.reid_radius_m:
            return False
        self.x[k] = self.measured[k] = self.last_seen[k] = z
        self.v[k] = 0.0
        self.cov[k] = (self.r, 0.0, self.initial_speed_var)
        self.missed[k] = 0
        self.hits[k] += 1
        self.views[k] = n_views
        hit[k] = True
        return True

    def _reid(self, z: NDArray[np.float64]) -> int | None:
        """The id of the remembered track last seen nearest to `z`, within `reid_radius_m` (then
        forgotten), or None."""
        if not self._lost:
            return None
        distances = [float(np.linalg.norm(z - where)) for _, where in self._lost]
        k = int(np.argmin(distances))
        if distances[k] > self.reid_radius_m:
            return None
        return self._lost.pop(k)[0]

    def _birth(self, t: float, z: NDArray[np.float64], n_views: int) -> None:
        i = self.count
        known = self._reid(z)
        if known is None:
            self.ids[i] = self._next_id
            self._next_id += 1
        else:  # a marker that stayed: its old id (rows are put back in id order after the frame)
            self.ids[i] = known
            self._reordered = self._reordered or (i > 0 and known < int(self.ids[i - 1]))
        self.times[i] = t
        self.x[i] = z
        self.v[i] = 0.0
        self.cov[i] = (self.r, 0.0, self.initial_speed_var)
        self.hits[i] = 1
        self.missed[i] = 0
        self.confirmed[i] = False
        self.measured[i] = z
        self.views[i] = n_views
        self.last_seen[i] = z
        self.known[i] = known is not None
        self.count += 1
