"""A library that keeps learning: measured throws join the regression while the arm works.

`OnlineLibrary` starts from a trained `ThrowLibrary` and the hyperparameters of its training fit
(`gp.GaussianProcess`), and takes every throw whose landing was measured (`add`). It serves the
planner like a `generalize.Generalizer` (`predict`, `params_for`, `area`) and writes itself back
as a `ThrowLibrary` (`library`) whose `meta["learning"]` keeps each throw's join number and the
history of updates (time, the throw, what was retired; the newest `MAX_HISTORY`, and how many
older ones were dropped).

Decisions, and why:

* **The refit keeps the training hyperparameters.** Maximising the marginal likelihood again on
  every throw is an SLSQP search per output (6), each step a factorisation and a gradient of
  O(N^3) (`gp`); a throw must be absorbed well inside the 10 ms control period. The lengths, signal and noise of each output,
  the input standardisation, the linear mean beta and the residual scale stay those of the
  training fit (the hyperparameters are in those units); only the solve is redone.
* **A drift is a slowly changing linear term, shared by nothing else.** After the hand's latency
  or the ball changes, old labels contradict new ones; but a drift (a release 15 ms late, a
  heavier ball) moves the landings of neighbouring throws alike: it changes the map smoothly,
  and the map's shape (the GP's residual f) still holds. So each throw's parameters are modelled
  as the training fit's linear mean, the shared residual f, and a linear term b(j) . H(x) whose
  coefficients follow an AR(1) process over the throws' join numbers j, starting at 0 with the
  training (Rasmussen and Williams, ch. 2.7 and 4.2: a sum of kernels). Per output m, with the
  standardised landings Xn, H = (1, Xn) and rho = exp(-1 / DRIFT_THROWS):

      c(j, j') = rho^|j - j'| (1 - rho^(2 min(j, j')))           (0 for the trained throws: j = 0)
      K_m = k_m(Xn, Xn) + s_b^2 (H H^T) * c(j, j) + sn_m^2 I      (s_b^2 = DRIFT_VARIANCE, * elementwise)
      alpha_m = K_m^-1 (Y[:, m] - H beta[:, m]) / r_std_m        (Cholesky, per output)
      theta(x*) = H(x*) beta + r_std * k*(x*) alpha,  k* = k_m(x*, Xn) + s_b^2 (H* H^T) * c(J, j)

  with J the newest join number: the prediction is for the conditions of the latest throws. Old
  throws are not forgotten: their labels are explained by the drift term of their time, and they
  keep telling the regression the map's shape where nothing newer landed; a few new throws fix the
  present drift term for the whole area (measured by the tests with a 20 mm shift of every
  landing: 21.6 mm median error before, 1-2 mm after 10 throws, and no loss without a drift).
  Before any throw joins, c = 0 everywhere and the regression is exactly the training fit.
* **The solve.** Every covariance entry depends only on its two throws (their landings and join
  numbers), so a joining throw adds one row and column, computed once and kept in a buffer (a
  retired throw's row and column are overwritten by the last throw's); the Cholesky factor of each
  output is then recomputed (six 200 x 200 factorisations, about 1-2 ms on one core; a bordered
  update would do without a retirement, but at the size bound every join retires one), with one
  BLAS thread, in place in a buffer made once (a fresh 200 x 200 array per output cost as much
  as its factorisation); measured by `wiithrow bench learning` (refit p50/p99: about 3 ms of CPU
  per join at 200 throws on this project's loaded 2-core host).
* **The least informative throws are retired.** A throw joining within `SUPERSEDE_M` of an older
  throw's landing supersedes it (the same neighbourhood, older conditions: the newer one says
  all the older one did, under today's conditions), and beyond `max_size` (200) the oldest go. The trained throws are
  not special: they retire by the same rules.
* **The trained area is the hull of the throws kept.** A measured landing beyond the area (a
  target served within the planner's margin, or a training throw of a larger area) grows it; a
  retired corner throw is superseded by a nearer one, so the area moves with the throws.
* **The sideways miss is learned beside the regression.** A throw's parameters move the ball in
  its plane only, so how far beside the plane the throws land (a joining throw's `across`) is
  learned by `lateral.LateralTerm` (`across`, what the planner aims away): fitted to the library's
  across labels when it starts (none: no correction), then a bounded Kalman step per joining
  throw that carries one. Its state is kept in `meta["learning"]["lateral"]` (a library that
  learnt before it was kept starts from the fit).

Pure: numpy, scipy and threadpoolctl (one BLAS thread for the solve), no app imports. Not
thread-safe: the session adds throws inside its operations, one at a time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cho_factor, cho_solve
from threadpoolctl import ThreadpoolController

from wiithrow.throwing.errors import LibraryFormatError, ThrowingError
from wiithrow.throwing.generalize import Generalizer, TrainedArea
from wiithrow.throwing.gp import GaussianProcess, GPHyperparameters
from wiithrow.throwing.lateral import LateralTerm
from wiithrow.throwing.library import ThrowLibrary, TrainedThrow
from wiithrow.throwing.representation import ThrowParameters
from wiithrow.throwing.throw_plane import xz

#: The drift process's memory, in throws joined (rho = exp(-1 / DRIFT_THROWS); module docstring).
DRIFT_THROWS = 50.0
#: The drift process's variance, in the residuals' standardised units (module docstring).
DRIFT_VARIANCE = 1.0
#: A joining throw supersedes older throws whose measured landings lie this close to its own (m).
SUPERSEDE_M = 0.03
#: The library's default bound on its size.
MAX_SIZE = 200
#: The most updates its history keeps (the newest; the number dropped is counted): an update is
#: 0.4 KB and 0.5 KB per throw it retired, so 5,000 keep the file within about 7 MB, inside the
#: bound a library file is read with (`vision.files.LIBRARY_SIZE`), whatever the years of joins.
MAX_HISTORY = 5_000
#: Added to the diagonal (times the signal's variance) when a factorisation fails without it.
JITTER = 1e-8
#: The key of `ThrowLibrary.meta` that keeps the online state and history.
META_KEY = "learning"

_blas: ThreadpoolController | None = None  # made once: finding the BLAS libraries takes a while


def _one_blas_thread() -> Any:
    """A context with one BLAS thread: a 200 x 200 Cholesky split over two threads of a loaded host
    waits for the other thread (measured: 79 ms for the six with two threads, 1.8 ms with one)."""
    global _blas
    if _blas is None:
        _blas = ThreadpoolController()
    return _blas.limit(limits=1, user_api="blas")


@dataclass(frozen=True)
class Update:
    """One throw joining the library: when (`time`, an ISO string the caller gives), the `throw`,
    its join number `joined`, where it came from (`source`: "training", "measure_landing",
    "simulated measurement", ...) and the throws `retired` for it, with the reason of each."""

    time: str
    throw: TrainedThrow
    joined: int
    source: str
    retired: tuple[tuple[TrainedThrow, str], ...]

    def to_dict(self) -> dict[str, object]:
        return {
            "time": self.time,
            "joined": self.joined,
            "source": self.source,
            "throw": self.throw.to_dict(),
            "retired": [{"throw": t.to_dict(), "reason": why} for t, why in self.retired],
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Update:
        try:
            return cls(
                str(d["time"]),
                TrainedThrow.from_dict(d["throw"]),
                int(d["joined"]),
                str(d["source"]),
                tuple((TrainedThrow.from_dict(r["throw"]), str(r["reason"])) for r in d["retired"]),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise LibraryFormatError(f"bad learning update {str(d)[:200]}: {exc}") from None


class OnlineLibrary:
    """A trained library that keeps learning (module docstring). Build it with `start`."""

    def __init__(
        self,
        library: ThrowLibrary,
        fit: GaussianProcess,
        joined: ArrayLike,
        history: tuple[Update, ...] = (),
        *,
        history_dropped: int = 0,
        max_size: int = MAX_SIZE,
        drift_throws: float = DRIFT_THROWS,
        supersede_m: float = SUPERSEDE_M,
        drift_variance: float = DRIFT_VARIANCE,
        lateral: LateralTerm | None = None,
    ) -> None:
        if not max_size >= 4:
            raise ThrowingError(f"a learning library keeps at least 4 throws, max_size is {max_size}")
        if not (drift_throws > 0 and supersede_m >= 0 and drift_variance >= 0):
            raise ThrowingError(
                f"drift_throws must be > 0, supersede_m and drift_variance >= 0, got {drift_throws}, {supersede_m}, "
                f"{drift_variance}"
            )
        self.arm, self.shape, self.ball = library.arm, library.shape, library.ball
        self.meta = {k: v for k, v in library.meta.items() if k != META_KEY}
        self.max_size, self.drift_throws, self.supersede_m = int(max_size), float(drift_throws), float(supersede_m)
        self.drift_variance = float(drift_variance)
        self.rho = math.exp(-1.0 / self.drift_throws)
        self.hyper: list[GPHyperparameters] = list(fit.hyper)
        self.x_mean, self.x_std, self.r_std = fit.x_mean.copy(), fit.x_std.copy(), fit.r_std.copy()
        self.beta = fit.beta.copy()  # the training fit's linear mean, kept: the drift term carries changes
        self.lengths = np.array([hp.lengths for hp in self.hyper])  # (m, d)
        self.signal2 = np.array([hp.signal**2 for hp in self.hyper])  # (m,)
        self.noise2 = np.array([hp.noise**2 for hp in self.hyper])  # (m,)
        self.throws: list[TrainedThrow] = list(library.throws)
        self.joined = np.asarray(joined, dtype=np.int64).copy()
        if self.joined.shape != (len(self.throws),):
            raise ThrowingError(f"{len(self.throws)} throws need as many join numbers, got {self.joined.shape}")
        self.history: list[Update] = list(history)[-MAX_HISTORY:]
        self.history_dropped = int(history_dropped) + len(history) - len(self.history)
        self.Xn = self._standardize(library.landings)
        self.Y = library.parameters
        # k_m(Xn, Xn) without the noise, in a buffer with room for one more than the bound: a
        # retired throw's row and column are overwritten by the last throw's, a new one's appended
        n, cap = len(self.throws), max(len(self.throws), self.max_size) + 1
        self._K = np.zeros((len(self.hyper), cap, cap))
        self._K[:, :n, :n] = self._covariance(self.Xn, self.joined, self.Xn, self.joined)
        self._work = np.empty(cap * cap)  # where each output's matrix is factorised: no allocation per join
        self._refit()
        self.lateral = lateral if lateral is not None else LateralTerm.fit(library.landings, library.across)

    @property
    def Kf(self) -> NDArray[np.float64]:
        """(m, N, N): the covariance of the throws kept without their noise (a view of the buffer)."""
        n = len(self.throws)
        return self._K[:, :n, :n]

    @classmethod
    def start(cls, library: ThrowLibrary, **options: Any) -> OnlineLibrary:
        """The learning library of `library`: its hyperparameters fitted once here (the training
        fit, `Generalizer`), the online state (join numbers, history) read from its
        `meta["learning"]` when it has learnt before, else all its throws at join number 0."""
        state = library.meta.get(META_KEY)
        if isinstance(state, dict) and "joined" in state:
            joined = np.asarray(state["joined"], dtype=np.int64)
            history = tuple(Update.from_dict(u) for u in state.get("history", []))
            options.setdefault("history_dropped", int(state.get("history_dropped", 0)))
            # the hyperparameters of the library it started from, kept with it, so that a reload
            # serves the same regression (a refit on today's throws would be another model)
            base = state.get("fit")
            fit = _fit_from_dict(base) if isinstance(base, dict) else Generalizer(library).gp
            lateral = state.get("lateral")
            if isinstance(lateral, dict):
                options.setdefault("lateral", LateralTerm.from_dict(lateral))
        else:
            joined, history = np.zeros(len(library), dtype=np.int64), ()  # trained together: all of age 0
            fit = Generalizer(library).gp
        return cls(library, fit, joined, history, **options)

    # -- the regression -------------------------------------------------------------------------

    def _standardize(self, X: ArrayLike) -> NDArray[np.float64]:
        return (np.atleast_2d(np.asarray(X, dtype=float)) - self.x_mean) / self.x_std

    def _kernel(self, A: NDArray[np.float64], B: NDArray[np.float64]) -> NDArray[np.float64]:
        """k_m(A, B) for every output m: (m, len(A), len(B))."""
        diff = A[None, :, None, :] - B[None, None, :, :]
        S = ((diff / self.lengths[:, None, None, :]) ** 2).sum(axis=3)
        K: NDArray[np.float64] = self.signal2[:, None, None] * np.exp(-0.5 * S)
        return K

    def _drift(self, ja: NDArray[np.int64], jb: NDArray[np.int64]) -> NDArray[np.float64]:
        """c(j, j') = rho^|j - j'| (1 - rho^(2 min(j, j'))): the covariance of the drift process
        between throws joined as j and j' (an AR(1) that starts at 0 with the training)."""
        a, b = ja.astype(float)[:, None], jb.astype(float)[None, :]
        c: NDArray[np.float64] = self.rho ** np.abs(a - b) * (1.0 - self.rho ** (2.0 * np.minimum(a, b)))
        return c

    def _covariance(
        self, A: NDArray[np.float64], ja: NDArray[np.int64], B: NDArray[np.float64], jb: NDArray[np.int64]
    ) -> NDArray[np.float64]:
        """(m, len(A), len(B)): k_m(A, B) + s_b^2 (H_A H_B^T) * c(ja, jb), without the noise."""
        HA = np.hstack([np.ones((len(A), 1)), A])
        HB = np.hstack([np.ones((len(B), 1)), B])
        drift = self.drift_variance * (HA @ HB.T) * self._drift(ja, jb)
        out: NDArray[np.float64] = self._kernel(A, B) + drift[None, :, :]
        return out

    def _refit(self) -> None:
        """Per output, the Cholesky solve (module docstring)."""
        n = len(self.throws)
        H = np.hstack([np.ones((n, 1)), self.Xn])
        R = (self.Y - H @ self.beta) / self.r_std
        alphas = []
        diagonal = np.arange(n)
        with _one_blas_thread():
            Kf = self.Kf
            K = self._work[: n * n].reshape(n, n).T  # Fortran order: LAPACK factorises it in place
            for m in range(self.Y.shape[1]):
                np.copyto(K, Kf[m])  # symmetric: the transposed view holds the same matrix
                K[diagonal, diagonal] += self.noise2[m]
                try:
                    cf = cho_factor(K, lower=True, overwrite_a=True, check_finite=False)
                except np.linalg.LinAlgError:  # two landings nearly alike at the training fit's tiny noise
                    np.copyto(K, Kf[m])
                    K[diagonal, diagonal] += self.noise2[m] + JITTER * self.signal2[m]
                    cf = cho_factor(K, lower=True, overwrite_a=True, check_finite=False)
                alphas.append(cho_solve(cf, R[:, m], check_finite=False))
        self.alpha = np.array(alphas)  # (m, N)
        self.area = TrainedArea(np.array([t.landing for t in self.throws]))

    def predict_vector(self, X: ArrayLike) -> NDArray[np.float64]:
        """Parameter vectors (M, 2n) for landings X (M, 2) in link1."""
        Z = self._standardize(X)
        now = np.full(Z.shape[0], self.joined.max(), dtype=np.int64)  # the newest throw's conditions
        Ks = self._covariance(Z, now, self.Xn, self.joined)  # (m, M, N)
        f = np.einsum("kmn,kn->mk", Ks, self.alpha)
        H = np.hstack([np.ones((Z.shape[0], 1)), Z])
        out: NDArray[np.float64] = H @ self.beta + f * self.r_std
        return out

    def predict(self, target: ArrayLike) -> ThrowParameters:
        """Parameters for `target` (x, z) in link1, without the area check."""
        return ThrowParameters.from_vector(self.predict_vector(xz(target)[None, :])[0])

    def params_for(self, target: ArrayLike, margin: float = 0.0) -> ThrowParameters:
        """Parameters for `target` (x, z) in link1; OutsideTrainedAreaError more than `margin` (m)
        outside the area (as `Generalizer.params_for`)."""
        if not margin >= 0:
            raise ThrowingError(f"margin must be >= 0 m, got {margin}")
        self.area.check(target, margin)
        return self.predict(target)

    def across(self, target: ArrayLike) -> float:
        """The across offset (m) a throw served for `target` (x, z) lands beside its plane, as
        learned so far (`lateral.LateralTerm`)."""
        return self.lateral.across(xz(target))

    # -- learning -------------------------------------------------------------------------------

    def __len__(self) -> int:
        return len(self.throws)

    def add(self, throw: TrainedThrow, *, time: str, source: str) -> Update:
        """`throw` (its parameters and measured landing) joins: older throws it supersedes and,
        beyond `max_size`, the oldest retire; the regression is solved again, and its across
        offset, if it has one, updates the sideways term (`lateral`). ThrowingError (and nothing
        changes) for a throw of another shape or a non-finite landing."""
        if not isinstance(throw, TrainedThrow):
            raise ThrowingError(f"a joining throw is a TrainedThrow, got {type(throw).__name__}")
        if throw.params.q_release.size != self.shape.n:
            raise ThrowingError(
                f"the throw has {throw.params.q_release.size} joints, the library's shape {self.shape.n}"
            )
        if not (np.isfinite(throw.landing).all() and np.isfinite(throw.params.vector).all()):
            raise ThrowingError("a throw joins only with a finite measured landing and parameters")
        landings = self.Xn * self.x_std + self.x_mean
        near = np.hypot(*(landings - throw.landing).T) <= self.supersede_m
        retire = {
            int(i): f"superseded: landed within {self.supersede_m * 1e3:.0f} mm of the newer throw"
            for i in np.flatnonzero(near)
        }
        keep = len(self.throws) - len(retire) + 1
        if keep > self.max_size:
            order = [int(i) for i in np.argsort(self.joined, kind="stable") if int(i) not in retire]
            for i in order[: keep - self.max_size]:
                retire[i] = f"the oldest beyond the library's bound of {self.max_size} throws"
        # never fewer than a regression needs: of those to retire, the newest stay until 4 are kept
        while len(self.throws) - len(retire) + 1 < 4:
            del retire[max(retire, key=lambda i: self.joined[i])]
        retired = tuple((self.throws[i], retire[i]) for i in sorted(retire))
        number = int(self.joined.max()) + 1
        for i in sorted(retire, reverse=True):
            self._remove(i)
        n = len(self.throws)
        xn = self._standardize(throw.landing)
        j = np.array([number], dtype=np.int64)
        row = self._covariance(xn, j, np.vstack([self.Xn, xn]), np.append(self.joined, number))[:, 0, :]
        self._K[:, n, : n + 1] = self._K[:, : n + 1, n] = row
        self.Xn = np.vstack([self.Xn, xn])
        self.Y = np.vstack([self.Y, throw.params.vector])
        self.joined = np.append(self.joined, number)
        self.throws.append(throw)
        self._refit()
        if throw.across is not None:
            self.lateral.update(throw.landing, throw.across, self.area.vertices)
        update = Update(time, throw, number, source, retired)
        self.history.append(update)
        if len(self.history) > MAX_HISTORY:
            del self.history[0]
            self.history_dropped += 1
        return update

    def _remove(self, i: int) -> None:
        """Retire throw i: the last throw takes its place (its kernel row and column too)."""
        last = len(self.throws) - 1
        if i != last:
            self._K[:, i, : last + 1] = self._K[:, last, : last + 1]
            self._K[:, : last + 1, i] = self._K[:, : last + 1, last]
            self._K[:, i, i] = self._K[:, last, last]
            self.Xn[i], self.Y[i], self.joined[i] = self.Xn[last], self.Y[last], self.joined[last]
            self.throws[i] = self.throws[last]
        self.Xn, self.Y, self.joined = self.Xn[:last], self.Y[:last], self.joined[:last]
        self.throws.pop()

    # -- the library it is --------------------------------------------------------------------

    @property
    def library(self) -> ThrowLibrary:
        """The throws kept, as a `ThrowLibrary` whose `meta["learning"]` holds the join numbers,
        the training fit's hyperparameters and the history (what `start` reads back)."""
        state = {
            "joined": self.joined.tolist(),
            "fit": {
                "x_mean": self.x_mean.tolist(),
                "x_std": self.x_std.tolist(),
                "r_std": self.r_std.tolist(),
                "beta": self.beta.tolist(),
                "hyper": [
                    {"lengths": hp.lengths.tolist(), "signal": hp.signal, "noise": hp.noise, "nll": hp.nll}
                    for hp in self.hyper
                ],
            },
            "rules": {
                "drift_throws": self.drift_throws,
                "drift_variance": self.drift_variance,
                "supersede_m": self.supersede_m,
                "max_size": self.max_size,
            },
            "history": [u.to_dict() for u in self.history],
            "history_dropped": self.history_dropped,
            "lateral": self.lateral.to_dict(),
        }
        return ThrowLibrary(self.arm, self.shape, self.ball, tuple(self.throws), {**self.meta, META_KEY: state})


def batch_fit(
    library: ThrowLibrary, fit: GaussianProcess, joined: ArrayLike, *, drift_throws: float = DRIFT_THROWS
) -> OnlineLibrary:
    """The same regression solved from scratch on `library`'s throws at join numbers `joined` (the
    reference the online updates are checked against)."""
    return OnlineLibrary(library, fit, joined, drift_throws=drift_throws, max_size=max(MAX_SIZE, len(library)))


def _fit_from_dict(d: Mapping[str, Any]) -> GaussianProcess:
    """A `GaussianProcess` holding only the hyperparameters and scalings `OnlineLibrary` keeps."""
    try:
        gp = GaussianProcess()
        gp.x_mean = np.asarray(d["x_mean"], dtype=float)
        gp.x_std = np.asarray(d["x_std"], dtype=float)
        gp.r_std = np.asarray(d["r_std"], dtype=float)
        gp.beta = np.asarray(d["beta"], dtype=float)
        gp.hyper = [
            GPHyperparameters(
                np.asarray(h["lengths"], dtype=float), float(h["signal"]), float(h["noise"]), float(h["nll"])
            )
            for h in d["hyper"]
        ]
    except (KeyError, TypeError, ValueError) as exc:
        raise LibraryFormatError(f"bad learning fit in the library: {exc}") from None
    if not all(math.isfinite(h.signal) and math.isfinite(h.noise) for h in gp.hyper):
        raise LibraryFormatError("bad learning fit in the library: non-finite hyperparameters")
    return gp
