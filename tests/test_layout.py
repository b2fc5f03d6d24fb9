"""The project's layout: one import name, every package installed, short documented modules.

The rules are written in docs/architecture.md ("Layout"); the layers themselves are checked by
import-linter in `make lint` (pyproject.toml's contract).
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import tomllib
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("app", "vision", "robot", "throwing", "web")
#: Modules may run longer than this only when docs/architecture.md says why ("Long modules").
MAX_LINES = 500


def package_folders() -> list[Path]:
    return sorted(p.parent for folder in FOLDERS for p in (ROOT / folder).rglob("__init__.py"))


def modules() -> list[Path]:
    return sorted(p for folder in (*FOLDERS, "wiithrow") for p in (ROOT / folder).rglob("*.py"))


def test_every_package_folder_is_installed_under_wiithrow():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    for folder in package_folders():
        name = "wiithrow." + ".".join(folder.relative_to(ROOT).parts)
        assert name in listed, f"{folder.relative_to(ROOT)} is a package but pyproject.toml does not install {name}"
    assert "package-dir" not in config, "wiithrow/'s links are the layout: a package-dir mapping would hide it again"


@pytest.mark.parametrize("folder", FOLDERS)
def test_the_package_root_links_each_folder_so_source_tools_see_the_installed_layout(folder):
    link = ROOT / "wiithrow" / folder
    assert link.is_symlink(), f"wiithrow/{folder} is not a link to ../{folder} (a checkout without symbolic links?)"
    assert link.readlink() == Path("..", folder), f"wiithrow/{folder} points at {link.readlink()}, not ../{folder}"
    assert link.resolve() == (ROOT / folder).resolve()


def test_a_wheel_installs_only_the_one_name_with_the_linked_folders_copied_in(tmp_path):
    """The links are followed when the wheel is built: site-packages gets `wiithrow/` and nothing else."""
    import shutil
    import zipfile

    source = tmp_path / "checkout"  # a copy, so that setuptools' build/ folder stays out of the checkout
    skip = shutil.ignore_patterns(".venv", ".git", "build", "*.egg-info", "__pycache__", ".*_cache", "tests", "docs")
    shutil.copytree(ROOT, source, symlinks=True, ignore=skip)
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(source)],
        check=True, capture_output=True, timeout=300, cwd=tmp_path,
    )  # fmt: skip
    (wheel,) = tmp_path.glob("wiithrow-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {"wiithrow", wheel.name.split("-py3")[0] + ".dist-info"}
    for folder in FOLDERS:
        assert f"wiithrow/{folder}/__init__.py" in names, f"the wheel lacks wiithrow/{folder}/"
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    for package, patterns in package_data.items():
        folder = ROOT.joinpath(*package.split(".")[1:])
        for pattern in patterns:
            for path in folder.glob(pattern):
                inside = "wiithrow/" + path.relative_to(ROOT).as_posix()
                assert inside in names, f"the wheel lacks {inside} (package-data of {package})"


def _install_faults(stderr: str) -> list[str]:
    """What an install printed that is not this host's own pip configuration (an index location it skips)."""
    return [line for line in stderr.splitlines() if line.strip() and not HOST_PIP_NOTE.match(line)]


#: pip's note about an index location in this host's pip configuration: the machine's, not the project's.
HOST_PIP_NOTE = re.compile(r"^WARNING: Location '.*' is ignored")


def test_the_makefiles_editable_install_prints_nothing(tmp_path):
    """`make demo` and `make test` install editable, quietly: setuptools reports no data folder as a
    package it would ignore (include-package-data is off; package-data lists the data), and its
    editable-install notice is filtered by the Makefile's QUIET_EDITABLE."""
    import shutil

    source = tmp_path / "checkout"
    skip = shutil.ignore_patterns(".venv", ".git", "build", "*.egg-info", "__pycache__", ".*_cache", "site")
    shutil.copytree(ROOT, source, symlinks=True, ignore=skip)
    quiet = re.search(r'^QUIET_EDITABLE := (\w+)="([^"]*)"', (ROOT / "Makefile").read_text(), re.M)
    assert quiet, "the Makefile defines QUIET_EDITABLE"
    env = {**os.environ, quiet[1]: quiet[2]}
    # into an environment of its own (pip --python): an install with --prefix uninstalls the
    # checkout's own wiithrow from the running environment first
    target = tmp_path / "env"
    venv.create(target, with_pip=False)
    result = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(target / "bin" / "python"), "install", "--no-deps",
         "--quiet", "-e", str(source)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    assert list(target.glob("lib/python*/site-packages/__editable__.wiithrow-*.pth")), "nothing was installed"
    faults = _install_faults(result.stdout + result.stderr)
    assert not faults, f"the install printed {len(faults)} lines, first: {faults[:5]}"


@pytest.mark.parametrize("bare", FOLDERS)
def test_outside_the_checkout_only_the_one_name_imports(tmp_path, bare):
    code = f"import wiithrow.{bare}\ntry:\n    import {bare}\nexcept ImportError:\n    print('absent')\n"
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "absent", f"`import {bare}` works outside the checkout"


def test_modules_are_short_or_the_architecture_says_why():
    allowed = _long_modules_allowed()
    for path in modules():
        lines = len(path.read_text().splitlines())
        name = str(path.relative_to(ROOT))
        if lines > MAX_LINES:
            assert name in allowed, f"{name} has {lines} lines: split it, or say why in docs/architecture.md"


def test_every_module_says_what_it_owns():
    for path in modules():
        if path.name == "__init__.py" and not path.read_text().strip():
            pytest.fail(f"{path.relative_to(ROOT)} is empty: a package's __init__ says what the package owns")
        tree = ast.parse(path.read_text())
        assert ast.get_docstring(tree), f"{path.relative_to(ROOT)} has no module docstring"


def test_the_architecture_document_names_every_package_and_module():
    text = (ROOT / "docs" / "architecture.md").read_text()
    for path in modules():
        rel = path.relative_to(ROOT)
        if path.name == "__init__.py":
            assert f"{rel.parent}/" in text, f"docs/architecture.md does not mention the package {rel.parent}/"
        else:
            assert rel.name.removesuffix(".py") in text, f"docs/architecture.md does not mention {rel}"


def test_no_code_cites_files_outside_the_repository():
    for path in [*modules(), *sorted((ROOT / "tests").rglob("*.py"))]:
        if path == Path(__file__).resolve():
            continue
        assert "DESIGN.md" not in path.read_text(), (
            f"{path.relative_to(ROOT)} cites DESIGN.md, which is not in the repository"
        )


def _long_modules_allowed() -> set[str]:
    text = (ROOT / "docs" / "architecture.md").read_text()
    section = text.split("## Long modules", 1)[1].split("\n## ", 1)[0] if "## Long modules" in text else ""
    return set(re.findall(r"`([\w/]+\.py)`", section))
