"""The rig's calibration file and the DLTdv/easyWand coefficient CSV."""

import json

import numpy as np
import pytest

from wiithrow.app.calibration.points import calibrate_rig
from wiithrow.vision import FileFormatError, StereoCalibration, load_dlt_coefficients, save_dlt_coefficients
from wiithrow.vision.rig import observe_all, points_in_common_view, stereo_rig


@pytest.fixture(scope="module")
def calibrated():
    cams = stereo_rig()
    rng = np.random.default_rng(0)
    X = points_in_common_view(cams, 30, rng)
    image = observe_all(cams, X, rng)
    return cams, calibrate_rig(X, image)


def test_json_round_trip_keeps_everything(tmp_path, calibrated):
    _, result = calibrated
    path = result.calibration.save(tmp_path / "cal.json")
    loaded = StereoCalibration.load(path)
    assert loaded.frame == "link1"
    assert loaded.loo_error_m == pytest.approx(result.loo.mean)
    assert np.array_equal(loaded.Ps, result.calibration.Ps)
    for a, b in zip(loaded.cameras, result.calibration.cameras):
        assert a.method == b.method and a.rms_px == pytest.approx(b.rms_px)
        assert np.allclose(a.decompose().K, b.decompose().K)


def test_corrupt_calibration_file_is_reported_not_overwritten(tmp_path, calibrated):
    _, result = calibrated
    path = result.calibration.save(tmp_path / "cal.json")
    path.write_text(path.read_text()[:200])
    with pytest.raises(FileFormatError, match="cal.json"):
        StereoCalibration.load(path)


def test_dlt_csv_round_trip_and_layout(tmp_path, calibrated):
    cams, result = calibrated
    path = save_dlt_coefficients(tmp_path / "dlt.csv", result.calibration.Ps)
    rows = path.read_text().strip().splitlines()
    assert len(rows) == 11 and all(len(r.split(",")) == 2 for r in rows)
    Ps = load_dlt_coefficients(path)
    assert np.allclose(Ps[:, 2, 3], 1.0)
    X = points_in_common_view(cams, 50, np.random.default_rng(1))
    for P, cam in zip(Ps, result.calibration.cameras):
        assert np.allclose(
            cam.project(X), (X @ P[:, :3].T + P[:, 3])[:, :2] / (X @ P[2, :3] + P[2, 3])[:, None], atol=1e-6
        )


def test_dlt_csv_vertical_flip(tmp_path, calibrated):
    cams, _ = calibrated
    Ps = np.stack([c.P for c in cams])
    save_dlt_coefficients(tmp_path / "flip.csv", Ps, flip_v_height=768)
    flipped = load_dlt_coefficients(tmp_path / "flip.csv")  # as a bottom-left-origin tool reads it
    X = points_in_common_view(cams, 10, np.random.default_rng(2))
    ours = cams[0].project(X)
    theirs = X @ flipped[0, :, :3].T + flipped[0, :, 3]
    theirs = theirs[:, :2] / theirs[:, 2:]
    assert np.allclose(theirs[:, 0], ours[:, 0]) and np.allclose(theirs[:, 1], 768 - ours[:, 1])
    back = load_dlt_coefficients(tmp_path / "flip.csv", flip_v_height=768)
    assert np.allclose(back[0] / back[0, 2, 3], Ps[0] / Ps[0, 2, 3])


@pytest.mark.parametrize(
    "content, message", [("1,2\n" * 10, "11 rows"), ("a,b\n" * 11, "not a DLT"), ("nan,1\n" * 11, "NaN")]
)
def test_bad_dlt_csv(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(FileFormatError, match=message):
        load_dlt_coefficients(path)


def _edit(path, change):
    document = json.loads(path.read_text())
    change(document)
    path.write_text(json.dumps(document))


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["cameras"][0].update(P=[[0.0] * 4] * 3), "cam0: its projection matrix is degenerate"),
        (lambda d: d["cameras"][0].update(P=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]]), "cam0: its projection"),
        (lambda d: d["cameras"][1].update(P=d["cameras"][0]["P"]), "cam0 and cam1 have the same centre"),
        (lambda d: d["cameras"][0].update(P=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, float("nan"), 1]]), "non-finite"),
        (lambda d: d.update(cameras=d["cameras"][:1]), "at least 2 calibrated cameras"),
    ],
)
def test_broken_calibrations_are_refused_when_loaded(tmp_path, calibrated, change, message):
    """An all-zero P (a LinAlgError traceback in `throw` and `track`) and two identical cameras
    (triangulation errors of 200-7,400 px, exit 0) are caught where the file is read."""
    _, result = calibrated
    path = result.calibration.save(tmp_path / "cal.json")
    _edit(path, change)
    with pytest.raises(FileFormatError, match=message) as info:
        StereoCalibration.load(path)
    assert str(path) in str(info.value)


def test_no_leave_one_out_is_stored_as_null(tmp_path, calibrated):
    _, result = calibrated
    calibration = StereoCalibration(result.calibration.cameras, "link1", float("nan"))
    path = calibration.save(tmp_path / "cal.json")
    assert json.loads(path.read_text())["loo_error_m"] is None
    assert StereoCalibration.load(path).loo_error_m is None
