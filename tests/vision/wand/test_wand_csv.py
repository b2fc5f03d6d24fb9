"""The wand CSV: t, then c<i>_a_u, c<i>_a_v, c<i>_b_u, c<i>_b_v per camera; NaN where unseen."""

import numpy as np
import pytest

from tests.helpers.wand_rigs import arc_of_three
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.wand.observations import WandObservations, from_dots
from wiithrow.vision.wand.wand_csv import header, read_wand_csv, write_wand_csv
from wiithrow.vision.wand.waver import wave_wand


def test_round_trip_keeps_every_pixel_and_every_gap(tmp_path):
    rig = arc_of_three()
    observations, _ = wave_wand(rig.cameras, 2, np.random.default_rng(0), dropout=0.2, depth_m=rig.depth_m)
    assert np.isnan(observations.pixels).any()  # some dots missing
    path = write_wand_csv(tmp_path / "wand.csv", observations)
    assert path.read_text().splitlines()[0] == ",".join(header(3))
    back = read_wand_csv(path)
    assert np.array_equal(back.t, observations.t)
    assert np.array_equal(back.pixels, observations.pixels, equal_nan=True)


def test_empty_cells_are_unseen(tmp_path):
    path = tmp_path / "wand.csv"
    path.write_text(",".join(header(2)) + "\n0.0,1,2,3,4,,,,\n0.01,5,6,nan,nan,7,8,9,10\n")
    back = read_wand_csv(path)
    assert back.cameras == 2 and back.frames == 2
    assert np.isnan(back.pixels[1, 0]).all() and np.isnan(back.pixels[0, 1, 1]).all()
    assert back.pixels[1, 1, 1].tolist() == [9.0, 10.0]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty"),
        ("t,u0,v0,u1,v1\n0,1,2,3,4\n", "line 1 must be the header"),
        (",".join(header(2)) + "\n0,1,2,3\n", "line 2 has 4 columns"),
        (",".join(header(2)) + "\n0,1,2,3,4,5,6,7,x\n", "line 2, column c1_b_v: 'x' is not a number"),
        (",".join(header(2)) + "\nnan,1,2,3,4,5,6,7,8\n", "finite time"),
        (",".join(header(2)) + "\n0,1,nan,3,4,5,6,7,8\n", "one coordinate NaN"),
        (",".join(header(2)) + "\n1,1,2,3,4,5,6,7,8\n0,1,2,3,4,5,6,7,8\n", "in order"),
    ],
)
def test_a_file_that_is_not_a_wand_csv_is_refused_with_its_name(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=message) as info:
        read_wand_csv(path)
    assert str(path) in str(info.value)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(FileFormatError, match="no such file"):
        read_wand_csv(tmp_path / "absent.csv")


def test_dot_frames_give_two_one_or_no_ends():
    dots = np.full((3, 2, 4, 2), np.nan)  # 3 frames, 2 cameras, 4 slots
    dots[0, 0, [1, 3]] = [[10, 11], [20, 21]]  # two dots: both ends, slot order kept
    dots[1, 0, 2] = [30, 31]  # one dot: end a only
    dots[2, 0, :3] = [[1, 1], [2, 2], [3, 3]]  # three dots (a stray source): nothing
    observations = from_dots([0.0, 0.01, 0.02], dots)
    assert isinstance(observations, WandObservations)
    assert observations.pixels[0, 0].tolist() == [[10, 11], [20, 21]]
    assert observations.pixels[0, 1, 0].tolist() == [30, 31] and np.isnan(observations.pixels[0, 1, 1]).all()
    assert np.isnan(observations.pixels[0, 2]).all() and np.isnan(observations.pixels[1]).all()
