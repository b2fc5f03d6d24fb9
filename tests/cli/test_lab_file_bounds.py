"""Files from a lab's disk, as the user meets them on the command line: too large, out of range,
naming a path outside their folder, made for another arm. Each is exit status 2 and one line (the
file, what is wrong, the bound), never a traceback or a library's warning, and an oversized file
is refused before it is read: the memory a refusal costs is measured in a process of its own."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from wiithrow.robot import spec_of

WIITHROW = str(Path(sys.executable).with_name("wiithrow"))
#: How large the oversized files are: beyond every bound, and far beyond what the refusal may cost.
OVERSIZED_BYTES = 80 * 10**6
#: What refusing an oversized file may add to a process's peak resident memory (MB): nothing of
#: the file is read (the loader itself costs a few MB the first time it runs).
REFUSAL_GROWTH_MB = 16.0

#: One loader per kind of file, run in a fresh process after the imports: the peak RSS growth of
#: the call (MB) and its error are printed as JSON.
_LOADERS = {
    "settings": "from wiithrow.app.settings import Settings as L; load = L.load",
    "calibration": "from wiithrow.vision import StereoCalibration as L; load = L.load",
    "library": "from wiithrow.app.throws.library_file import load_library as load",
    "progress": (
        "from pathlib import Path\n"
        "from wiithrow.app.throws.training_file import load_run\n"
        "load = lambda p: load_run(p, Path(p).with_name('lib.json'))"
    ),
}
_MEASURE = """
import json, resource, sys
{loader}
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
try:
    load(sys.argv[1])
    error = None
except Exception as exc:
    error = f"{{type(exc).__name__}}: {{exc}}"
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"growth_mb": (after - before) / 1024, "error": error}}))
"""


def _valid_start(kind: str, tmp_path: Path) -> str:
    """A valid file of `kind` (what the oversized file starts with)."""
    if kind == "settings":
        return '{"kind": "wiithrow.settings", "schema": 1, "settings": {}}'
    if kind == "calibration":
        from wiithrow.app.worlds import SimWorld

        return SimWorld(seed=0).true_calibration().to_text()
    if kind == "library":
        from wiithrow.app.throws.library_file import default_library_path

        return default_library_path().read_text()
    from wiithrow.app.throws.training_file import save_run
    from wiithrow.app.throws.training_run import TrainingRun
    from wiithrow.throwing import Area

    path = save_run(tmp_path / "lib.training.json", TrainingRun.start("pa10", Area((1.0, 1.6), (0.0, 0.4)), 6))
    return path.read_text()


def _oversized(path: Path, start: str) -> Path:
    """`start` followed by spaces to OVERSIZED_BYTES: valid JSON, as large as asked."""
    with path.open("w") as handle:
        handle.write(start)
        pad = OVERSIZED_BYTES - len(start)
        chunk = " " * 2**20
        while pad > 0:
            handle.write(chunk[: min(pad, len(chunk))])
            pad -= len(chunk)
    return path


@pytest.mark.parametrize("kind", list(_LOADERS))
def test_an_oversized_file_is_refused_in_one_line_before_it_is_read(tmp_path, kind):
    path = _oversized(tmp_path / f"big_{kind}.json", _valid_start(kind, tmp_path))
    script = _MEASURE.format(loader=_LOADERS[kind])
    result = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    measured = json.loads(result.stdout.strip().splitlines()[-1])
    error = measured["error"]
    assert error is not None, f"an {OVERSIZED_BYTES / 1e6:.0f} MB {kind} file was read: {measured}"
    assert f"{path}: 80.0 MB, more than a" in error and "MiB" in error and "\n" not in error, error
    assert measured["growth_mb"] < REFUSAL_GROWTH_MB, measured


def _run(*argv: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([WIITHROW, *argv], capture_output=True, text=True, timeout=timeout)


def _one_line(err: str) -> str:
    lines = [line for line in err.strip().splitlines() if not line.startswith("world: ")]
    assert len(lines) == 1 and "Traceback" not in err and "Warning" not in err, err
    return lines[0]


def _settings(tmp_path: Path, arm_spec: dict) -> Path:
    path = tmp_path / "lab" / "settings.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps({"kind": "wiithrow.settings", "schema": 1, "settings": {"arm_spec": arm_spec}}))
    return path


@pytest.mark.parametrize(
    "change, needle",
    [
        ({"velocity": [1e9] * 6}, "arm_spec: velocity[0] must be a number from 0 to 50 rad/s, got 1e+09"),
        ({"acceleration": [1e9] * 6}, "arm_spec: acceleration[0] must be a number from 0 to 1000 rad/s^2"),
        ({"jerk": [1.0] * 5 + [1e12]}, "arm_spec: jerk[5] must be a number from 0 to 100000 rad/s^3"),
        ({"lower": [-1e6] * 6}, "arm_spec: lower[0] must be a number from -12.5664 to 12.5664 rad"),
        ({"urdf": "wiithrow:../../etc/passwd"}, "arm_spec: urdf 'wiithrow:../../etc/passwd' leaves the package's"),
        ({"urdf": "../outside.urdf"}, "arm_spec: urdf '../outside.urdf' is outside the settings file's folder"),
        ({"urdf": "/etc/passwd"}, "arm_spec: urdf '/etc/passwd' is outside the settings file's folder"),
    ],
)
def test_serve_refuses_arm_settings_out_of_range_or_outside_their_folder(tmp_path, change, needle):
    path = _settings(tmp_path, spec_of("ur5e").to_dict() | {"name": "lab_ur"} | change)
    result = _run("serve", "--settings", str(path), "--duration", "0.1", "--port", "0")
    assert result.returncode == 2, result.stderr
    line = _one_line(result.stderr)
    assert line.startswith(f"wiithrow serve: {path}: ") and needle in line, line


def test_serve_refuses_an_oversized_settings_file_in_one_line(tmp_path):
    path = _oversized(tmp_path / "settings.json", _valid_start("settings", tmp_path))
    result = _run("serve", "--settings", str(path), "--duration", "0.1", "--port", "0")
    assert result.returncode == 2, result.stderr
    line = _one_line(result.stderr)
    assert line.startswith(f"wiithrow serve: {path}: 80.0 MB, more than a settings file may be (1 MiB"), line


def test_a_throw_target_beyond_the_arms_reach_is_one_line(tmp_path):
    result = _run("throw", "--sim", "--world", "kinematic", "--target", "1e300", "0", "0.2", "--dry-run")
    assert result.returncode == 2, result.stderr
    line = _one_line(result.stderr)
    assert line.startswith("wiithrow throw: the target (1e+300, 0, 0.2) m in base is beyond") and "pa10" in line, line


def _calibration(tmp_path: Path, change) -> Path:
    from wiithrow.app.worlds import SimWorld

    document = json.loads(SimWorld(seed=0).true_calibration().to_text())
    change(document)
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(document))
    return path


def test_a_projection_matrix_entry_of_1e308_is_one_line_and_no_numpy_warning(tmp_path):
    path = _calibration(tmp_path, lambda d: d["cameras"][0]["P"][0].__setitem__(0, 1e308))
    (tmp_path / "p.csv").write_text("u0,v0,u1,v1\n500,400,510,400\n")
    result = _run("triangulate", "--calibration", str(path), "--points", str(tmp_path / "p.csv"))
    assert result.returncode == 2, result.stderr
    line = _one_line(result.stderr)  # no RuntimeWarning: overflow
    assert line == (
        f"wiithrow triangulate: {path}: camera 0 (cam0): P[0][0] is 1e+308, beyond 1e+12 in magnitude: "
        "no camera's projection matrix has such an entry"
    ), line


def test_a_calibration_made_on_another_arm_is_refused_naming_both(tmp_path):
    """A robot calibration records the arm it was made on; one made on a Panda is not the PA-10's link1."""
    path = _calibration(tmp_path, lambda d: d.update(arm="panda"))
    result = _run(
        "throw", "--sim", "--world", "kinematic", "--target", "1.3", "0", "0", "--dry-run", "--calibration", str(path)
    )
    assert result.returncode == 2, result.stderr
    line = _one_line(result.stderr)
    assert line == (
        f"wiithrow throw: {path} was made on arm 'panda' (frame link1), and this arm is 'pa10': "
        "its link1 is another arm's; calibrate this rig on this arm (`wiithrow calibrate --robot`)"
    ), line
