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
        (
            lambda d: d["cameras"][0].update(P=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, float("nan"), 1]]),
            r"P\[2\]\[2\] is NaN",
        ),
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


NAN = float("nan")


def _set(field, index, value):
    """A change to camera 1's `field` (its entry at `index`, or the field itself for None)."""

    def change(d):
        camera = d["cameras"][1]
        if index is None:
            camera[field] = value
            return
        node = camera[field]
        for i in index[:-1]:
            node = node[i]
        node[index[-1]] = value

    return change


@pytest.mark.parametrize(
    "change, message",
    [
        (_set("P", (0, 1), NAN), r"camera 1 \(cam1\): P\[0\]\[1\] is NaN"),
        (_set("K", (0, 0), NAN), r"camera 1 \(cam1\): K\[0\]\[0\] is NaN"),
        (_set("K", (1, 2), float("inf")), r"camera 1 \(cam1\): K\[1\]\[2\] is inf"),
        (_set("R", (2, 2), NAN), r"camera 1 \(cam1\): R\[2\]\[2\] is NaN"),
        (_set("t", (1,), float("-inf")), r"camera 1 \(cam1\): t\[1\] is -inf"),
        (_set("center", (0,), NAN), r"camera 1 \(cam1\): center\[0\] is NaN"),
        (
            _set("rms_px", None, NAN),
            r"camera 1 \(cam1\): rms_px is NaN or infinite: every number in a calibration must be finite",
        ),
        (_set("rms_px", None, float("inf")), r"camera 1 \(cam1\): rms_px is NaN or infinite"),
        (_set("world", (3, 2), NAN), r"camera 1 \(cam1\): world\[3\]\[2\] is NaN"),
        (_set("image", (4, 0), None), r"camera 1 \(cam1\): image\[4\]\[0\] is null"),
        (_set("residuals_px", (5,), NAN), r"camera 1 \(cam1\): residuals_px\[5\] is NaN"),
        (_set("residuals_px", (5,), None), r"camera 1 \(cam1\): residuals_px\[5\] is null"),
        (_set("image_size", None, [1024, NAN]), r"camera 1 \(cam1\): image_size\[1\] is NaN or infinite"),
        (_set("image_size", None, [1024, 7.5]), r"camera 1 \(cam1\): image_size must be \[width, height\]"),
        (_set("inliers", None, [NAN]), r"camera 1 \(cam1\): inliers must be a list of true and false"),
        (_set("world", None, [[0.0, 0.0]]), r"camera 1 \(cam1\): world must be a N x 3 array"),
        (_set("P", None, "P"), r"camera 1 \(cam1\): P must be a 3 x 4 array"),
        (lambda d: d.update(loo_error_m=NAN), r"loo_error_m is NaN or infinite"),
        (lambda d: d.update(loo_error_m=-0.1), r"loo_error_m must be a distance >= 0"),
        (lambda d: d["meta"].update(fit={"rms": [0.1, NAN]}), r"meta\.fit\.rms\[1\] is NaN or infinite"),
        (lambda d: d.update(frame=7), r"'frame' must be a frame's name, got 7"),
        (lambda d: d.update(cameras={"a": 1}), r"'cameras' must be a list"),
    ],
)
def test_every_number_must_be_finite_and_the_message_names_camera_and_field(tmp_path, calibrated, change, message):
    """NaN in K, rms_px or loo_error_m was read without a word (issue 20); now every number is
    checked, and the one line says which camera and which field."""
    _, result = calibrated
    path = result.calibration.save(tmp_path / "cal.json")
    _edit(path, change)
    before = path.read_bytes()
    with pytest.raises(FileFormatError, match=message) as info:
        StereoCalibration.load(path)
    assert str(info.value).startswith(f"{path}: ")
    assert "\n" not in str(info.value)
    assert path.read_bytes() == before


def test_a_point_outside_the_fit_may_have_an_infinite_residual(tmp_path, calibrated):
    """The robust fit keeps a point behind the camera as an outlier with an infinite residual,
    written as null (strict JSON): that file is read back, the residual as inf."""
    _, result = calibrated
    path = result.calibration.save(tmp_path / "cal.json")

    def outlier(d):
        d["cameras"][0]["inliers"][2] = False
        d["cameras"][0]["residuals_px"][2] = None

    _edit(path, outlier)
    camera = StereoCalibration.load(path).cameras[0]
    assert camera.residuals_px[2] == np.inf and not camera.inliers[2]
    assert np.isfinite(camera.rms_px)


@pytest.mark.parametrize("depth", [33, 1000, 100_000])
def test_nested_calibration_is_one_line_not_a_recursion_error(tmp_path, depth):
    path = tmp_path / "cal.json"
    path.write_text('{"kind": "wiithrow.calibration", "schema": 1, "meta": ' + "[" * depth + "]" * depth + "}")
    with pytest.raises(FileFormatError, match="nested deeper than 32 levels") as info:
        StereoCalibration.load(path)
    assert str(info.value).startswith(f"{path}: ")


def test_from_dict_reads_what_to_dict_gives_and_checks_it(calibrated):
    """In memory a camera without fitted points has rms_px NaN (a file holds null): to_dict's
    output is read back; an infinite or negative rms_px is not."""
    from wiithrow.vision.dlt import CalibratedCamera
    from wiithrow.vision.errors import CalibrationError

    _, result = calibrated
    camera = result.calibration.cameras[0]
    bare = CalibratedCamera(camera.P, "true", np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool))
    assert np.array_equal(CalibratedCamera.from_dict(bare.to_dict()).P, camera.P)
    assert CalibratedCamera.from_dict(camera.to_dict()).rms_px == pytest.approx(camera.rms_px)
    for rms in (float("inf"), -1.0, float("nan")):
        with pytest.raises(CalibrationError, match="rms_px must be a number >= 0 or null"):
            CalibratedCamera.from_dict({**camera.to_dict(), "rms_px": rms})
