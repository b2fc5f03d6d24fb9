"""Compile what every process of the suite would otherwise compile for itself, once, before the suite
starts: `python -m tests.warm_up` (`make test` and `make test-fast` run it beside the linters).

* **Bytecode**: the project's and the tests' modules as `.pyc` (`compileall`). Where the environment
  sets PYTHONDONTWRITEBYTECODE (this workplace's machines do), no process writes them, so each of the
  suite's workers and each of its subprocesses (the `wiithrow` commands, the writer processes)
  compiled every module it imported from source: about 6% of the suite's CPU in a profile of a
  whole run (py-spy, `SourceLoader.get_code`).
* **The test modules as pytest rewrites them** (its assertion rewriting, cached beside each module
  as `*-pytest-*.pyc` unless bytecode writing is off): a collection with writing on, so that each
  worker reads them instead of rewriting every module (collecting the suite: 9.6 s of CPU per worker
  without the cache, 4.0 s with it).
* **The numba kernels** (`wiithrow.vision.kernels`, the MuJoCo servo cycle): a fresh checkout has no
  cache, and each worker and each subprocess that started before one had written it compiled the
  kernels on its own (about 15 s of CPU each, measured). Here the paths that call them run once, so
  that the cache holds each signature the suite uses: a simulated rig tracking its markers
  (synchronising, matching, triangulating, the Kalman tracks), a batch triangulation with and
  without refinement, a leave-one-out, the projection of predicted markers, and the MuJoCo world's
  servo cycle. (A signature the suite needs and this misses is compiled where it is first used, as
  before: slower, never wrong.)

A run that finds everything compiled costs a few seconds. Nothing here is a test: it only makes
caches, which every process would make anyway.
"""

from __future__ import annotations

import compileall
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The real folders (compileall does not follow `wiithrow/`'s links to them; the `.pyc` of
#: `wiithrow/app/x.py` is `app/__pycache__/x.*.pyc`, the same file through the link).
SOURCES = ("wiithrow", "app", "vision", "robot", "throwing", "web", "tests", "examples")


def compile_bytecode() -> bool:
    return all(compileall.compile_dir(ROOT / folder, quiet=1, workers=1) for folder in SOURCES)


def rewrite_test_modules() -> bool:
    """Collect the suite once with bytecode writing on (pytest keeps what it rewrote); True when
    the collection worked."""
    import contextlib
    import io

    import pytest

    sys.dont_write_bytecode = False
    with contextlib.redirect_stdout(io.StringIO()):
        code = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", str(ROOT / "tests")])
    return code == 0


def compile_kernels() -> None:
    import numpy as np

    from wiithrow.app.rig.waiting import pump
    from wiithrow.app.session import simulated_session
    from wiithrow.vision import kernels
    from wiithrow.vision.crossval import leave_one_out
    from wiithrow.vision.triangulation import triangulate

    for world in ("kinematic", "mujoco"):  # the rig's tracking path, and the MuJoCo servo cycle
        rig_world = simulated_session(seed=0, world=world, calibration="true", quiet=True, learn=False).world
        pump(rig_world.clock, rig_world.rig, 0.5)
        Ps = np.stack([camera.P for camera in rig_world.cameras])
        rig_world.close()
    points = np.random.default_rng(0).uniform(-0.3, 0.3, (40, 3)) + np.array([1.2, 0.0, 0.2])
    image = np.einsum("cij,nj->cni", Ps, np.column_stack([points, np.ones(len(points))]))
    image = image[..., :2] / image[..., 2:]
    triangulate(Ps, image)
    triangulate(Ps, image, refine=True)
    leave_one_out(points, image)
    kernels.project(Ps, points, np.empty((len(Ps), len(points), 2)))  # the matching of predicted markers


def main() -> int:
    start = time.monotonic()
    ok = compile_bytecode() and rewrite_test_modules()
    compile_kernels()
    print(f"tests.warm_up: bytecode and numba kernels ready in {time.monotonic() - start:.1f} s", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
