"""`wiithrow train`: the library is saved last, its output checked first, its default never
replaced without --force. The 25 throws (tested in tests/cli/test_train_run.py) are replaced here
by the shipped library's, measured at once (`tests.helpers.shipped_run`), to test what the command
does around them."""

import pytest

from tests.helpers.shipped_run import shipped_run
from wiithrow.app.cli.main import main
from wiithrow.app.throws.library_file import load_library
from wiithrow.app.throws.training_file import load_run, progress_path


@pytest.fixture()
def quick_training(monkeypatch):
    """`train.throw_the_run` measures the shipped library's throws at once; counts its calls."""
    from wiithrow.app.cli.commands import train

    calls = []

    def at_once(session, *args, **kwargs):
        calls.append(session)
        return shipped_run(session)

    monkeypatch.setattr(train, "throw_the_run", at_once)
    return calls


@pytest.fixture()
def calibration(sim_world, tmp_path):
    return str(sim_world.true_calibration().save(tmp_path / "cal.json"))


def test_an_interruption_after_training_leaves_the_old_library(
    tmp_path, capsys, monkeypatch, quick_training, calibration
):
    """SIGINT about 4 s in said "interrupted" after the library had been replaced. The measured
    throws stay in the progress file, to resume: nothing measured is lost either."""
    from wiithrow.app.cli.commands import train

    out = tmp_path / "library.json"
    out.write_text("the library of last week")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(train, "leave_one_out_error", interrupted)
    assert main(["train", "--sim", "--world", "kinematic", "--calibration", calibration, "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert quick_training and "interrupted" in err and "25 measured throws kept" in err and "--resume" in err
    assert out.read_text() == "the library of last week"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json", "library.json", "library.training.json"]
    kept = load_run(progress_path(out), out)
    assert kept is not None and kept.measured == 25 and kept.complete


@pytest.mark.parametrize("target, needle", [(lambda d: d / "afile" / "l.json", "is a file"), (lambda d: d, "folder")])
def test_an_unwritable_out_is_refused_before_the_throws(tmp_path, capsys, quick_training, calibration, target, needle):
    (tmp_path / "afile").write_text("x")
    assert (
        main(["train", "--sim", "--world", "kinematic", "--calibration", calibration, "--out", str(target(tmp_path))])
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.startswith("wiithrow train: cannot write") and needle in err and len(err.splitlines()) == 1
    assert quick_training == []


def test_the_default_library_is_not_replaced_without_force(tmp_path, capsys, monkeypatch, quick_training, calibration):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "library.json").write_text("mine")
    assert main(["train", "--sim", "--world", "kinematic", "--calibration", calibration]) == 2
    assert "library.json exists and --out does not name it" in capsys.readouterr().err
    assert (tmp_path / "library.json").read_text() == "mine" and quick_training == []
    assert main(["train", "--sim", "--world", "kinematic", "--calibration", calibration, "--force"]) == 0
    assert len(load_library(tmp_path / "library.json")) == 25
