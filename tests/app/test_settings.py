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


def _every_number_key():
    """(dotted key, default) of every numeric setting, found from the dataclasses themselves: a new
    number without a range would not be in `number()`'s metadata and fails
    `test_every_number_has_a_range`."""
    import dataclasses

    def walk(cls, prefix):
        for f in dataclasses.fields(cls):
            default = getattr(cls(), f.name)
            if dataclasses.is_dataclass(default):
                yield from walk(type(default), prefix + f.name + ".")
            elif not isinstance(default, str) and "object" not in f.metadata:  # arm_spec: a JSON object
                yield prefix + f.name, f, default

    return list(walk(Settings, ""))


def _nest(key, value):
    *parents, last = key.split(".")
    data = {last: value}
    for parent in reversed(parents):
        data = {parent: data}
    return data


def test_every_number_has_a_range_and_the_defaults_are_in_it():
    keys = _every_number_key()
    assert len(keys) >= 25
    for key, f, _default in keys:
        assert "range" in f.metadata, key
    assert Settings.from_dict(Settings().to_dict()) == Settings()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), float("-inf"), 1e12, -1e12, True, "1", None, [1]])
def test_every_number_refuses_non_finite_out_of_range_and_wrong_kinds_naming_its_key(bad):
    for key, _, default in _every_number_key():
        value = [bad] * len(default) if isinstance(default, tuple) and not isinstance(bad, list) else bad
        with pytest.raises(AppError) as info:
            Settings.from_dict(_nest(key, value), source="s.json")
        message = str(info.value)
        assert message.startswith(f"s.json: {key}"), message
        assert "must be" in message and "\n" not in message


@pytest.mark.parametrize(
    "data, message",
    [
        ({"rig": {"baseline": float("nan")}}, "rig.baseline must be a number from 0.01 to 2 m, got nan"),
        ({"rig": {"count": 2.5}}, "rig.count must be a whole number from 2 to 4, got 2.5"),
        ({"rig": {"center": [0.1, 0.0]}}, r"rig.center must be a list of 3 numbers, got \[0.1, 0.0\]"),
        ({"rig": {"center_px": [512, 800]}}, r"rig.center_px\[1\] must be a number from 0 to 768 px, got 800"),
        ({"ball": {"mass_kg": -0.1}}, "ball.mass_kg must be a number from 0.001 to 10 kg"),
        ({"mujoco": {"timestep_s": 0}}, "mujoco.timestep_s must be a number from 1e-05 to 0.01 s"),
        ({"rig": {"sensitivity": "level9"}}, "rig.sensitivity: unknown IR sensitivity 'level9'"),
        ({"rig": {"ir_format": "huge"}}, "rig.ir_format: unknown IR format 'huge'"),
    ],
)
def test_bad_numbers_are_one_line_naming_the_key_and_the_range(data, message):
    with pytest.raises(AppError, match=message):
        Settings.from_dict(data, source="s.json")


def test_numbers_in_range_are_kept_exactly():
    s = Settings.from_dict({"rig": {"baseline": 2, "count": 4.0, "center_px": [0, 768]}, "mujoco": {"seed": 7}})
    assert s.rig.baseline == 2.0 and isinstance(s.rig.baseline, float)
    assert s.rig.count == 4 and isinstance(s.rig.count, int)
    assert s.rig.center_px == (0.0, 768.0) and s.mujoco.seed == 7


def test_a_nan_token_in_a_settings_file_names_the_file_and_key(tmp_path):
    path = tmp_path / "s.json"
    path.write_text('{"kind": "wiithrow.settings", "schema": 1, "settings": {"rig": {"baseline": NaN}}}')
    with pytest.raises(AppError, match=f"^{path}: rig.baseline must be a number from 0.01 to 2 m, got nan$"):
        Settings.load(path)


@pytest.mark.parametrize("depth", [33, 5000])
def test_a_nested_settings_file_is_one_line(tmp_path, depth):
    path = tmp_path / "s.json"
    path.write_text('{"kind": "wiithrow.settings", "schema": 1, "settings": ' + "[" * depth + "]" * depth + "}")
    with pytest.raises(FileFormatError, match="nested deeper than 32 levels") as info:
        Settings.load(path)
    assert str(info.value).startswith(f"{path}: ")
