"""The robot package's boundaries: what it may import, and its public API."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

from wiithrow import robot

ROBOT_DIR = Path(robot.__file__).resolve().parent
ALLOWED = {"numpy", "scipy", "pinocchio", "ruckig"} | set(sys.stdlib_module_names)
FORBIDDEN = {"vision", "app", "throwing", "web"}


def imported_top_level_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_robot_imports_only_what_it_may():
    files = sorted(ROBOT_DIR.rglob("*.py"))
    assert len(files) >= 9
    for f in files:
        mods = imported_top_level_modules(f)
        assert not (mods & FORBIDDEN), f"{f.name} imports {mods & FORBIDDEN}"
        assert mods <= ALLOWED | {"wiithrow"}, f"{f.name} imports {mods - ALLOWED}"


def test_public_api():
    for name in robot.__all__:
        assert hasattr(robot, name), name
    for name in (
        "load_arm",
        "ArmModel",
        "solve_position",
        "plan_move",
        "plan_stop",
        "JointTrajectory",
        "SimulatedArm",
        "Arm",
        "JointState",
        "Clock",
        "RobotError",
        "UnreachableError",
        "LimitError",
    ):
        assert name in robot.__all__


def test_urdf_ships_with_the_package():
    assert (ROBOT_DIR / "urdf" / "pa10.urdf").is_file()
