"""Settings files: partial files keep defaults, typos and bad values are refused."""

import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.settings import Settings
from wiithrow.vision.errors import FileFormatError


def test_round_trip_and_partial_files(tmp_path):
    custom = Settings().replace(arm="ur5")
    path = custom.save(tmp_path / "s.json")
    assert Settings.load(path) == custom
    partial = Settings.from_dict({"rig": {"baseline": 0.3}, "noise": {"pixel_sigma_px": 1}})
    assert partial.rig.baseline == 0.3 and partial.rig.count == 2 and partial.noise.pixel_sigma_px == 1.0


@pytest.mark.parametrize(
    "data, message",
    [
        ({"rig": {"baselin": 0.3}}, "unknown RigSettings"),
        ({"noise": {"pixel_sigma_px": "big"}}, "must be a number"),
        ({"rig": 3}, "expected an object"),
    ],
)
def test_bad_settings_name_the_problem(data, message):
    with pytest.raises(AppError, match=message):
        Settings.from_dict(data)


def test_corrupt_file(tmp_path):
    path = tmp_path / "s.json"
    path.write_text("{")
    with pytest.raises(FileFormatError, match="s.json"):
        Settings.load(path)
