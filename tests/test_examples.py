"""Every script in examples/ runs as a user would run it, and says what it should."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: What each example must print (a regular expression over its output), beyond exiting with 0.
EXPECT = {
    "01_calibrate_and_triangulate.py": r"leave-one-out 3D error: \d\.\d\d mm",
    "02_track_simulated_remotes.py": r"marker 3: .* mm from the nearest true marker",
    "03_plan_and_validate_a_throw.py": r"validator: ok[\s\S]*refused: target \(3\.000, 0\.200\) m",
    "04_calibration_in_opencv_terms.py": r"cam1: fx 1\d{3}\.\d px",
    "05_throw_in_the_simulated_world.py": (
        r"alignment converged[\s\S]*landed \d+\.\d mm \(along [+-]\d+\.\d, across [+-]\d+\.\d\) from the target"
    ),
    "06_another_arm_in_mujoco.py": r"panda: trained 9 throws[\s\S]*median landing error \d+\.\d mm",
}


def test_every_example_is_listed():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(EXPECT)


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_example_runs(name, tmp_path):
    result = subprocess.run(
        [sys.executable, str(EXAMPLES / name)], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert re.search(EXPECT[name], result.stdout), result.stdout
