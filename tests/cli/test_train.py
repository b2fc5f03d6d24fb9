"""`wiithrow train`: the library is saved last, its output checked first, its default never
replaced without --force. The 25 simulated throws (tested in tests/app/test_training.py) are
replaced here by the shipped library, to test what the command does around them."""

import pytest

from wiithrow.app.cli.main import main
from wiithrow.app.throws.library_file import load_library


@pytest.fixture()
def quick_training(monkeypatch):
    """`train_in_world` returns the shipped library at once, and counts its calls."""
    from wiithrow.app.cli.commands import train

    calls = []

    def shipped(world, rng, **kwargs):
        calls.append(world)
        return load_library()

    monkeypatch.setattr(train, "train_in_world", shipped)
    return calls


@pytest.fixture()
def calibration(sim_world, tmp_path):
    return str(sim_world.true_calibration().save(tmp_path / "cal.json"))


def test_an_interruption_after_training_leaves_the_old_library(
    tmp_path, capsys, monkeypatch, quick_training, calibration
):
    """SIGINT about 4 s in said "interrupted" after the library had been replaced."""
    from wiithrow.app.cli.commands import train

    out = tmp_path / "library.json"
    out.write_text("the library of last week")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(train, "leave_one_out_error", interrupted)
    assert main(["train", "--sim", "--world", "kinematic", "--calibration", calibration, "--out", str(out)]) == 130
    assert quick_training and "interrupted" in capsys.readouterr().err
    assert out.read_text() == "the library of last week"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json", "library.json"]


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
