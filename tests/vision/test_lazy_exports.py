"""`wiithrow.vision`, `wiithrow.vision.wiimote` and `wiithrow.app.recording` import their public names
when first read (`wiithrow.lazy_exports`): the same objects as their submodules', and a process that
needs one submodule (a publisher's writer process) imports neither scipy nor numba; the Foxglove
writer process, which needs `vision.geometry` (scipy.linalg), not the tracker nor the session."""

import importlib
import subprocess
import sys

import pytest

import wiithrow.app.recording
import wiithrow.vision
import wiithrow.vision.wiimote

HEAVY = ("scipy", "numba", "pinocchio", "mujoco", "viser")


@pytest.mark.parametrize("package", [wiithrow.vision, wiithrow.vision.wiimote, wiithrow.app.recording])
def test_every_public_name_is_its_submodules_object(package):
    homes = package._HOMES
    assert sorted(package.__all__) == sorted(homes)
    for name, home in homes.items():
        assert getattr(package, name) is getattr(importlib.import_module(f"{package.__name__}.{home}"), name)
        assert name in dir(package)
    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        package.no_such_name  # noqa: B018


def test_triangulate_is_the_function_whichever_is_imported_first():
    code = (
        "import wiithrow.vision.triangulation; from wiithrow.vision import triangulate; "
        "import wiithrow.vision as v; print(callable(triangulate) and v.triangulate is triangulate)"
    )
    assert (
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
        == "True"
    )


@pytest.mark.parametrize(
    "module",
    [
        "wiithrow.vision",
        "wiithrow.vision.files",
        "wiithrow.vision.wiimote.frames",
        "wiithrow.app.channels.zenoh_writer",
    ],
)
def test_a_process_that_needs_one_submodule_imports_no_heavy_library(module):
    code = f"import sys, {module}; print(sorted(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60).stdout
    assert out.strip() == "[]", out


def test_the_foxglove_writer_process_imports_neither_the_tracker_nor_the_session():
    unwanted = ("numba", "scipy.optimize", "wiithrow.app.rig.pipeline", "wiithrow.app.session", "pinocchio", "mujoco")
    code = (
        f"import sys, wiithrow.app.channels.foxglove_writer; print(sorted(m for m in {unwanted!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60).stdout
    assert out.strip() == "[]", out
