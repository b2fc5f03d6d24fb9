"""Random CSV, JSON and flag values fed to every command's entry point, in-process (hypothesis).

For every command: the exit status is 0 or 2 (never an exception out of `main`, so never a
traceback), a failure is one line on stderr naming the command, and no file in the working folder
changes (content, mode, presence) unless the command succeeded. The files a command may read are
random: CSV of numbers, empty cells, NaN, inf, text and ragged rows; JSON that is random, a valid
document with one value replaced (by a random value, NaN, an infinity, or arrays nested too deep
to read) or one key removed, truncated, or valid as it is. Flags get
valid values, values of the wrong kind, NaN, infinities, negative numbers and paths that cannot be
written (a folder, a path under a file, /sys, /dev/null, an existing file the user did not name).

What is bounded so that a valid run stays short: track runs at most 0.1 s, a robot calibration at
most 8 poses, demo and serve at most 0.2 s, reproduce is only given folders it must refuse (a
valid quick run, 20 s, is tested in tests/app/test_reproduce.py), bench only its quick, short
benchmarks. `train`'s 25 simulated throws are replaced by the shipped library (the throws are
tested in tests/app/test_training.py; what train does with its inputs and output is not
replaced). The simulated rig's kept calibration lives outside the working folder (conftest), so
it is not a file the command changed.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wiithrow.app.cli.main import main

PATHS = [
    "points.csv",
    "pixels.csv",
    "cal.json",
    "lib.json",
    "settings.json",
    "calibration.json",
    "afile",
    "afile/x.json",
    "adir",
    "missing.json",
    "new/out.json",
    "out.csv",
    "/sys/x.json",
    "/dev/null",
]
JUNK = ["", "-", "nan", "-nan", "inf", "-inf", "1e309", "0", "-1", "-1e-3", "7", "2.5", "abc", "9" * 25, "é", "--json"]
NUMBERS = ["0", "1", "-1", "0.1", "1.3", "-0.2", "1e-9", "1e9", "nan", "inf", "-inf", "x"]


def _property(max_examples: int, *, slow: bool = False):
    """A hypothesis test drawing its own data (`data.draw`), `max_examples` runs; marked `slow`
    (left out of `make test-fast`) when its valid runs take seconds."""

    def decorate(test):
        test = given(data=st.data())(test)
        test = settings(
            max_examples=max_examples,
            deadline=None,
            suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
        )(test)
        return pytest.mark.slow(test) if slow else test

    return decorate


FAST = _property(40)
SLOW = _property(12, slow=True)


# -- random files -------------------------------------------------------------------------------

cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-2000, 2000).map(str),
    st.sampled_from(["", "nan", "inf", "-inf", "x", "u0", " ", "1e309", "0x10"]),
)


@st.composite
def csv_text(draw):
    """Rows of random cells (ragged or not), a header or not; or calibration-like rows."""
    width = draw(st.integers(0, 9))
    rows = draw(st.lists(st.lists(cell, min_size=width, max_size=width + draw(st.integers(0, 1))), max_size=12))
    if draw(st.booleans()):
        rows.insert(0, ["x", "y", "z", "u0", "v0", "u1", "v1"][:width])
    if draw(st.booleans()):  # points that can calibrate, some of them spoiled
        rows = [[repr(v) for v in row] for row in draw(_plausible_points())] + rows[: draw(st.integers(0, 2))]
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerows(rows)
    return out.getvalue()


@st.composite
def _plausible_points(draw):
    import numpy as np

    from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig

    cams = stereo_rig()
    rng = np.random.default_rng(draw(st.integers(0, 3)))
    n = draw(st.integers(1, 12))
    X = points_in_common_view(cams, n, rng)
    image = observe_all(cams, X, rng)
    return np.column_stack([X, image.transpose(1, 0, 2).reshape(n, -1)]).tolist()


json_value = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers(-(10**6), 10**6) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


def _valid_documents() -> dict[str, str]:
    from wiithrow.app.settings import Settings
    from wiithrow.app.throws.library_file import default_library_path
    from wiithrow.app.worlds import SimWorld
    from wiithrow.vision.files import versioned_json_text

    return {
        "cal.json": SimWorld(seed=0).true_calibration().to_text(),
        "lib.json": default_library_path().read_text(),
        "settings.json": versioned_json_text("wiithrow.settings", 1, {"settings": Settings().to_dict()}),
    }


VALID = _valid_documents()


NESTED = '"(nested)"'  # replaced by arrays nested too deep to read (see json_text)


@st.composite
def json_text(draw, name):
    """Random JSON; the valid document with one value replaced (by a random one, by NaN or an
    infinity, or by arrays nested 33 to 5,000 deep) or one key removed; truncated; or valid."""
    kind = draw(st.sampled_from(["random", "replaced", "non-finite", "nested", "removed", "truncated", "valid"]))
    if kind == "random":
        return json.dumps(draw(json_value))
    text = VALID[name]
    if kind == "valid":
        return text
    if kind == "truncated":
        return text[: draw(st.integers(0, len(text) - 1))]
    document = json.loads(text)
    node = document
    while True:  # walk down to a random container
        keys = list(node) if isinstance(node, dict) else list(range(len(node)))
        if not keys:
            break
        key = draw(st.sampled_from(keys))
        child = node[key]
        if isinstance(child, dict | list) and child and draw(st.booleans()):
            node = child
            continue
        if kind == "removed" and isinstance(node, dict):
            del node[key]
        elif kind == "non-finite":
            node[key] = draw(st.sampled_from([float("nan"), float("inf"), float("-inf")]))
        elif kind == "nested":
            node[key] = json.loads(NESTED)
        else:
            node[key] = draw(json_value)
        break
    text = json.dumps(document)  # NaN and infinities as the NaN and Infinity tokens
    depth = draw(st.sampled_from([33, 40, 999, 5000]))
    return text.replace(NESTED, "[" * depth + "]" * depth)


# -- a working folder, and what changed in it ---------------------------------------------------


def _snapshot(root: Path) -> dict[str, tuple]:
    state = {}
    for path in sorted(root.rglob("*")):
        info = path.lstat()
        content = path.read_bytes() if path.is_file() else None
        state[str(path.relative_to(root))] = (path.is_dir(), content, info.st_mode & 0o7777)
    return state


@contextlib.contextmanager
def working_folder(files: dict[str, str]):
    """A fresh folder with the given files, `afile` (a file) and `adir/` (holding a file), as cwd."""
    with tempfile.TemporaryDirectory() as name:
        root = Path(name)
        for file, text in files.items():
            (root / file).write_text(text)
        (root / "afile").write_text("a file")
        (root / "adir").mkdir()
        (root / "adir" / "keep.txt").write_text("the user's")
        saved = os.getcwd()
        os.chdir(root)
        try:
            yield root
        finally:
            os.chdir(saved)


def run_and_check(capsys, argv, files):
    with working_folder(files) as root:
        before = _snapshot(root)
        capsys.readouterr()
        code = main(argv)
        err = capsys.readouterr().err
        assert code in (0, 2), (argv, code, err)
        assert "Traceback" not in err, (argv, err)
        if code != 0:
            assert err.strip() and err.strip().splitlines()[-1].startswith("wiithrow"), (argv, err)
            assert _snapshot(root) == before, (argv, err)
    return code


def random_files(draw):
    return {
        "points.csv": draw(csv_text()),
        "pixels.csv": draw(csv_text()),
        "cal.json": draw(json_text("cal.json")),
        "lib.json": draw(json_text("lib.json")),
        "settings.json": draw(json_text("settings.json")),
        **({"calibration.json": "the user's calibration"} if draw(st.booleans()) else {}),
    }


def flags(draw, options):
    """A random subset of `options`, in random order: {flag: None} is a switch, {flag: (good,
    bad)} takes a value, three times as often one of `good` as one of `bad` (so that runs get
    past the parser, into the files and the work, as often as they stop at a flag)."""
    argv = []
    for flag, values in draw(st.permutations(list(options.items()))):
        if draw(st.integers(0, 2)) != 0:
            continue
        argv.append(flag)
        if values is not None:
            good, bad = values
            argv.append(draw(st.sampled_from(list(good) * 3 + list(bad))))
    return argv


ANY_PATH = (PATHS, JUNK)


# -- the commands -------------------------------------------------------------------------------


@FAST
def test_calibrate_from_files_and_the_demo(capsys, data):
    draw = data.draw
    if draw(st.integers(0, 3)) == 0:
        argv = ["calibrate", "--demo"] + flags(draw, {"--seed": (["0", "1"], JUNK), "--json": None, "--out": ANY_PATH})
    else:
        argv = ["calibrate", "--points", draw(st.sampled_from(["points.csv"] * 4 + PATHS + JUNK))]
        argv += flags(
            draw,
            {
                "--method": (["paper", "normalized", "refined", "robust"], ["magic"]),
                "--out": (["cal-out.json", "new/out.json", "calibration.json"], PATHS),
                "--dlt-csv": (["dlt.csv"], PATHS),
                "--frame": (["link1", "base"], [""]),
                "--seed": ([], JUNK),
                "--sim": None,
                "--force": None,
                "--json": None,
            },
        )
    run_and_check(capsys, argv, random_files(draw))


@SLOW
def test_calibrate_with_the_robot(capsys, data):
    draw = data.draw
    argv = [
        "calibrate",
        "--robot",
        "--sim",
        "--world",
        "kinematic",
        "--points",
        draw(st.sampled_from(["6", "7", "8", "5", "x", "-1", "nan"])),
    ]
    argv += flags(
        draw,
        {
            "--method": (["normalized", "refined"], ["x"]),
            "--out": (["cal-out.json", "calibration.json"], PATHS),
            "--dlt-csv": (["dlt.csv"], PATHS),
            "--seed": (["0", "1"], ["-1", "x"]),
            "--frame": ([], ["link1"]),
            "--force": None,
            "--json": None,
        },
    )
    run_and_check(capsys, argv, random_files(draw))


@FAST
def test_triangulate(capsys, data):
    draw = data.draw
    argv = ["triangulate"] + flags(
        draw,
        {
            "--calibration": (["cal.json"], PATHS + JUNK),
            "--points": (["pixels.csv", "points.csv"], PATHS + JUNK),
            "--out": (["xyz.csv", "new/xyz.csv"], PATHS + JUNK),
            "--refine": None,
        },
    )
    run_and_check(capsys, argv, random_files(draw))


@FAST
def test_track_and_devices(capsys, data):
    draw = data.draw
    if draw(st.integers(0, 4)) == 0:
        argv = ["devices"] + flags(draw, {"--json": None, "--all": None})
    else:
        duration = draw(st.sampled_from(["0.05", "0.1", "1e-9"] * 3 + ["0", "-1", "nan", "inf", "x"]))
        argv = ["track", "--duration", duration] + flags(
            draw,
            {
                "--sim": None,
                "--calibration": (["cal.json"], PATHS + JUNK),
                "--format": (["jsonl", "csv"], ["xml"]),
                "--out": (["rows.csv", "new/rows.jsonl"], PATHS + JUNK),
                "--record": (["run.mcap", "new/run.mcap"], PATHS + JUNK),
                "--speed": (["0.5", "3"], NUMBERS),
                "--realtime": None,
                "--seed": (["0", "5"], JUNK),
            },
        )
    run_and_check(capsys, argv, random_files(draw))


@SLOW
def test_train(capsys, data, monkeypatch):
    from tests.helpers.shipped_run import shipped_run
    from wiithrow.app.cli.commands import train

    monkeypatch.setattr(train, "throw_the_run", lambda session, *args, **kwargs: shipped_run(session))
    draw = data.draw
    argv = ["train", "--world", "kinematic"] + flags(
        draw,
        {
            "--sim": None,
            "--out": (["lib-out.json", "new/lib.json"], PATHS + JUNK),
            "--force": None,
            "--calibration": (["cal.json"], PATHS + JUNK),
            "--seed": (["0"], ["-1", "x", "1.5"]),
            "--json": None,
            "--resume": None,
            "--on-lost": (["retry", "skip", "stop"], ["maybe", "RETRY"]),
        },
    )
    run_and_check(capsys, argv, random_files(draw))


@FAST
def test_check_driver(capsys, data):
    """Random settings name no driver that loads (the valid ones none at all), so nothing moves:
    every run is refused, in one line, before the arm would."""
    draw = data.draw
    argv = [
        "check-driver",
        *draw(st.sampled_from([["--settings", "settings.json"], ["--settings", "missing.json"], []])),
    ]
    argv += flags(
        draw,
        {
            "--yes": None,
            "--json": None,
            "--out": (["new/out.json", "out.json"], PATHS + JUNK),
            "--calibration": (["cal.json"], PATHS + JUNK),
        },
    )
    assert run_and_check(capsys, argv, random_files(draw)) == 2


@SLOW
def test_throw(capsys, data):
    draw = data.draw
    target = draw(
        st.sampled_from([["1.3", "0", "0"], ["1.2", "0.4", "0.1"], ["1.3", "-2e-1", "0"]])
        | st.lists(st.sampled_from(["1.3", "0.1", "-1e-1", "0", "3", "nan", "-inf", "x"]), min_size=3, max_size=3)
    )
    argv = [
        "throw",
        "--target",
        *target,
        *draw(
            st.sampled_from(
                [
                    ["--sim", "--world", "kinematic"],
                    ["--sim", "--world", "kinematic"],
                    ["--sim", "--world", "kinematic"],
                    [],
                ]
            )
        ),
    ]
    argv += draw(st.sampled_from([["--dry-run"], ["--yes"], []]))
    argv += flags(
        draw,
        {
            "--dry-run": None,
            "--json": None,
            "--calibration": (["cal.json"], PATHS + JUNK),
            "--library": (["lib.json"], PATHS + JUNK),
            "--margin": (["0", "0.05"], NUMBERS),
            "--seed": (["0"], ["-1", "x"]),
        },
    )
    run_and_check(capsys, argv, random_files(draw))


@FAST
def test_reproduce_serve_demo_bench(capsys, data):
    draw = data.draw
    command = draw(st.sampled_from(["reproduce", "serve", "demo", "bench"]))
    if command == "reproduce":  # only folders it must refuse: a valid quick run takes 20 s
        out = draw(st.sampled_from(["afile", "afile/out", "adir", "/sys/out", "/dev/null", "points.csv"]))
        argv = ["reproduce", "--out", out] + flags(
            draw, {"--quick": None, "--seed": (["0"], JUNK), "--no-progress": None}
        )
    elif command in ("serve", "demo"):
        argv = [command, "--duration", draw(st.sampled_from(["0.1", "0.1", "0", "-1", "nan", "x"]))]
        argv += flags(
            draw,
            {
                "--host": (["127.0.0.1", "localhost"], ["", "999.1.1.1", "no such host"]),
                "--port": (["0"], ["-1", "70000", "x"]),
                "--library": (["lib.json"], PATHS + JUNK),
                "--poses": (["7"], ["6", "0", "-1", "x"]),
                **(
                    {"--settings": (["settings.json"], PATHS + JUNK), "--calibration": (["cal.json"], PATHS)}
                    if command == "serve"
                    else {}
                ),
                **({"--seed": (["0"], JUNK)} if command == "demo" else {}),
            },
        )
        if command == "demo":
            argv.append("--no-calibrate")  # a calibration in the background outlives a 0.1 s run
    else:
        argv = ["bench", draw(st.sampled_from(["triangulate", "calibration", "nonsense", ""])), "--quick"]
        argv += flags(draw, {"--json": None})
    run_and_check(capsys, argv, random_files(draw))
