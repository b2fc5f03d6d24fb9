"""One line, always: a malformed URDF is the project's one line (urdfdom's own lines captured), a
calibration whose numbers overflow numpy is its one-line error with no warning lines, and while a
command runs warnings, log records and a thread's end are one line each."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import pytest

from wiithrow.app.cli.one_line import one_line_output
from wiithrow.listeners import Listeners
from wiithrow.robot import spec_of
from wiithrow.robot.arms import load_arm
from wiithrow.robot.errors import RobotError

WIITHROW = str(Path(sys.executable).with_name("wiithrow"))
#: A URDF urdfdom cannot build (a joint's child link does not exist) and one that is not XML.
UNBUILDABLE = (
    '<robot name="x"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="zz"/>'
    '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>\n'
)
NOT_XML = '<robot name="x"><link name="a"/>\n'


def _command_lines(stderr: str) -> list[str]:
    """stderr's lines less the line that names the world a command runs on."""
    return [line for line in stderr.strip().splitlines() if not line.startswith("world: ")]


@pytest.mark.parametrize(
    "urdf, needle",
    [(UNBUILDABLE, "Failed to build tree: child link [zz] of joint [j] not found"), (NOT_XML, "not well-formed XML")],
    ids=["unbuildable", "not-xml"],
)
def test_serve_with_a_bad_urdf_says_one_line_and_nothing_of_urdfdoms(tmp_path, capfd, urdf, needle):
    (tmp_path / "arm.urdf").write_text(urdf)
    spec = spec_of("pa10").to_dict() | {"name": "mine", "urdf": "arm.urdf"}
    settings = tmp_path / "settings.json"
    settings.write_text(json.dumps({"kind": "wiithrow.settings", "schema": 1, "settings": {"arm_spec": spec}}))
    result = subprocess.run(
        [WIITHROW, "serve", "--settings", str(settings), "--port", "0"],
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )
    assert result.returncode == 2, result.stderr
    lines = _command_lines(result.stderr)
    assert len(lines) == 1 and lines[0].startswith("wiithrow serve: arm 'mine': "), result.stderr
    assert needle in lines[0] and "Error:" not in result.stderr and "model.cpp" not in result.stderr

    with pytest.raises(RobotError, match="is not a URDF Pinocchio can read|is not well-formed XML"):  # in-process too
        load_arm(_spec(spec, tmp_path))
    assert capfd.readouterr().err == ""  # fd 2: urdfdom wrote nothing there


def _spec(document, folder):
    from wiithrow.robot.spec import ArmSpec

    return ArmSpec.from_dict(document | {"urdf": str(folder / "arm.urdf")})


def test_a_calibration_that_overflows_numpy_is_one_line_without_warnings(tmp_path):
    from wiithrow.app.worlds import SimWorld

    document = json.loads(SimWorld(seed=0).true_calibration().to_text())
    document["cameras"][0]["P"][0][0] = 1e308  # finite, and numpy's dot of it overflows
    (tmp_path / "cal.json").write_text(json.dumps(document))
    (tmp_path / "p.csv").write_text("u0,v0,u1,v1\n500,400,510,400\n")
    result = subprocess.run(
        [WIITHROW, "triangulate", "--calibration", "cal.json", "--points", "p.csv"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wiithrow triangulate: cal.json: "), result.stderr
    assert "Warning" not in result.stderr


def test_warnings_are_one_line_at_the_end_of_a_command_that_ends_well(capsys):
    with one_line_output("x"):
        for _ in range(3):  # one place: the filters (Python's default) let it through once
            warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
        warnings.warn("invalid value encountered in divide", RuntimeWarning, stacklevel=1)
        assert capsys.readouterr().err == ""  # nothing where they happen
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(
        "wiithrow x: 2 warnings, the first: RuntimeWarning: overflow encountered in multiply (test_one_line.py:"
    ), err


def test_a_command_that_fails_prints_no_warning_line_and_filters_still_decide(capsys):
    with pytest.raises(ValueError), one_line_output("x"):
        warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
        raise ValueError("the error the command reports")
    assert capsys.readouterr().err == ""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(RuntimeWarning), one_line_output("x"):  # a warning configured as an error still raises
            warnings.warn("overflow", RuntimeWarning, stacklevel=1)


def test_log_records_and_a_threads_end_are_one_line_each(capsys, monkeypatch):
    monkeypatch.setattr(logging.getLogger(), "handlers", [])  # as on the command line: nobody handles the root
    with one_line_output("x"):
        try:
            raise KeyError("slot")
        except KeyError:
            logging.getLogger("somelib").exception("a library failed\nover two lines")

        def broken() -> None:
            raise RuntimeError("the thread's fault")

        thread = threading.Thread(target=broken, name="worker")
        thread.start()
        thread.join()
    err = capsys.readouterr().err
    assert err.splitlines() == [
        "wiithrow x: somelib: a library failed over two lines: KeyError: 'slot'",
        "wiithrow x: thread worker stopped: RuntimeError: the thread's fault",
    ], err


def test_a_failing_listener_is_logged_once_per_kind_of_fault(caplog):
    listeners: Listeners[int] = Listeners("rig")
    listeners.subscribe(lambda event: 1 / event)
    with caplog.at_level(logging.ERROR, logger="wiithrow.listeners"):
        for _ in range(100):
            listeners.emit(0)
    assert listeners.failures == 100
    assert [r.getMessage() for r in caplog.records] == [
        "a listener of rig failed: ZeroDivisionError: division by zero (told once; the events go on)"
    ]
    assert all(r.exc_info is None for r in caplog.records)  # no traceback
