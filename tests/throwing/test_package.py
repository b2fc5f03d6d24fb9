"""The throwing package's boundaries: it imports only robot, numpy, scipy, ruckig and threadpoolctl, and its
public API is importable from the package."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from wiithrow import throwing

ALLOWED = {
    "wiithrow",
    "numpy",
    "scipy",
    "ruckig",
    "threadpoolctl",
    "__future__",
}  # threadpoolctl: online.py's one BLAS thread
PKG = Path(throwing.__file__).resolve().parent


def test_imports_only_allowed_packages():
    stdlib = set(sys.stdlib_module_names)
    for path in PKG.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [] if node.level else [node.module or ""]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                assert top in ALLOWED or top in stdlib, f"{path.name} imports {name}"


def test_importing_throwing_loads_no_vision_app_or_web():
    code = (
        "import sys, wiithrow.throwing; "
        "print(sorted(m for m in sys.modules if m.startswith(('wiithrow.vision', 'wiithrow.app', 'wiithrow.web'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_public_api():
    for name in throwing.__all__:
        assert hasattr(throwing, name), name
    assert issubclass(throwing.ThrowingError, ValueError)
    for exc in (
        throwing.OutsideTrainedAreaError,
        throwing.TrajectoryRejected,
        throwing.LibraryFormatError,
        throwing.NoLandingError,
        throwing.InfeasibleThrowError,
        throwing.UnreachableTargetError,
    ):
        assert issubclass(exc, throwing.ThrowingError)
