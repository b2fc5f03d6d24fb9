"""Figures derived from the session's results, computed away from the refresh loop.

Owns the dashboard's slow numbers: the calibration's leave-one-out error against the number of
points (`wiithrow.app.studies.figures.accuracy.loo_curve` on the poses the calibration measured) and the mono method
against the stereo rig (`wiithrow.app.studies.figures.mono.study_mono_vs_stereo`, on a simulated twin of the world).
They take seconds of CPU, so each runs in a fresh interpreter (`python -m wiithrow.web.analysis`, the job
and its result passed as pickles in a temporary directory) and never holds the interpreter lock of
the process that runs the 100 Hz tracking loop; a background thread waits for it. (Not
multiprocessing: its spawn start method re-runs the main script of whoever created the
dashboard.) Results arrive as futures.

Nothing here imports viser: the worker process imports this module.
"""

from __future__ import annotations

import pickle
import subprocess
import sys
import tempfile
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from wiithrow.app.settings import Settings
from wiithrow.vision import StereoCalibration

#: Sizes of the error-against-points curve (capped at the number of measured poses).
CURVE_SIZES = (7, 8, 10, 12, 15, 20, 25, 30, 40, 50, 60)
#: Beacon angles (deg) of the mono-against-stereo comparison.
MONO_ANGLES_DEG = tuple(float(a) for a in np.arange(5.0, 76.0, 10.0))


@dataclass(frozen=True)
class LooCurveData:
    """Mean leave-one-out 3D error (m) against the number of calibration points."""

    sizes: NDArray[np.float64]
    refined_m: NDArray[np.float64]
    paper_m: NDArray[np.float64]


@dataclass(frozen=True)
class MonoStereoData:
    """|depth error| (m) of the mono method and of the stereo rig against the beacon angle (deg)."""

    angle_deg: NDArray[np.float64]
    mono_m: NDArray[np.float64]
    stereo_m: NDArray[np.float64]


def loo_curve_data(
    world: NDArray[np.float64], image: NDArray[np.float64], seed: int = 0, draws: int = 2
) -> LooCurveData:
    """The error-against-points curve of one calibration's poses: world (N, 3), image (C, N, 2)."""
    from wiithrow.app.studies.figures.accuracy import loo_curve

    n = int(world.shape[0])
    sizes = tuple(s for s in CURVE_SIZES if s < n) + (n,)
    curve = loo_curve(
        world,
        image,
        np.random.default_rng(seed),
        sizes=sizes,
        draws=draws,
        methods=("paper", "refined"),
        show_progress=False,
    )
    return LooCurveData(np.array(curve.sizes, dtype=float), curve.mean("refined"), curve.mean("paper"))


def mono_stereo_data(settings: Settings, calibration: StereoCalibration, seed: int = 0) -> MonoStereoData:
    """Fig. 6's data with this calibration on a simulated twin of the world."""
    from wiithrow.app.studies.figures.mono import study_mono_vs_stereo

    result = study_mono_vs_stereo(settings, calibration, angles_deg=MONO_ANGLES_DEG, seed=seed)
    return MonoStereoData(
        np.asarray(result.angle_deg, float), np.abs(result.depth_error("mono")), np.abs(result.depth_error("stereo"))
    )


def run_isolated(function_name: str, *args, timeout_s: float = 600.0):
    """Run `function_name(*args)` (a function of this module) in a fresh interpreter
    (`python -m wiithrow.web.analysis`) and return its result. The calling thread only waits: the work
    holds no lock of this process. Raises RuntimeError with the worker's last words on failure."""
    with tempfile.TemporaryDirectory(prefix="wiithrow-analysis-") as tmp:
        job, out = Path(tmp) / "job.pickle", Path(tmp) / "result.pickle"
        job.write_bytes(pickle.dumps((function_name, args)))
        proc = subprocess.run(
            [sys.executable, "-m", "wiithrow.web.analysis", str(job), str(out)],
            capture_output=True,
            text=True,
            timeout=timeout_s,
        )
        if proc.returncode != 0 or not out.exists():
            tail = (proc.stderr or "").strip().splitlines()[-1:] or [f"exit status {proc.returncode}"]
            raise RuntimeError(f"{function_name} failed in its worker process: {tail[0]}")
        return pickle.loads(out.read_bytes())


_JOBS: dict[str, Callable[..., object]] = {"loo_curve_data": loo_curve_data, "mono_stereo_data": mono_stereo_data}


class Analysis:
    """Runs the functions above in worker processes, waited for by one background thread (or, with
    `use_process=False`, in that thread itself)."""

    def __init__(self, *, use_process: bool = True) -> None:
        self.use_process = use_process
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="wiithrow-analysis")

    def submit(self, function, *args) -> Future:
        if self.use_process:
            return self._executor.submit(run_isolated, function.__name__, *args)
        return self._executor.submit(function, *args)

    def loo_curve(self, world: NDArray[np.float64], image: NDArray[np.float64], seed: int = 0) -> Future:
        return self.submit(loo_curve_data, np.asarray(world), np.asarray(image), seed)

    def mono_vs_stereo(self, settings: Settings, calibration: StereoCalibration, seed: int = 0) -> Future:
        return self.submit(mono_stereo_data, settings, calibration, seed)

    def close(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)


def _main(argv: list[str]) -> int:
    """`python -m wiithrow.web.analysis JOB OUT`: run one pickled job, pickle its result to OUT."""
    import wiithrow.web.analysis as module  # not __main__: the result's classes must unpickle in the caller

    name, args = pickle.loads(Path(argv[0]).read_bytes())
    result = module._JOBS[name](*args)
    Path(argv[1]).write_bytes(pickle.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
