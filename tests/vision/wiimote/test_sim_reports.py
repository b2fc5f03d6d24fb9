"""The simulated remote's frames and report bytes: the fast paths equal the plain ones."""

import numpy as np
import pytest

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote.input_reports import encode_ir_report, parse
from wiithrow.vision.wiimote.ir_dots import MISSING
from wiithrow.vision.wiimote.protocol import ProtocolError
from wiithrow.vision.wiimote.sim_reports import CameraFrame, SimulatedCamera, encode_frame, frame_fields

IR_REPORTS = (0x33, 0x36, 0x37, 0x3E, 0x3F)
CAM = WiimoteCamera.at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def random_frame(rng: np.random.Generator) -> CameraFrame:
    frame = CameraFrame()
    for s in range(4):
        if rng.random() < 0.7:
            frame.slots[s] = (s, int(rng.integers(0, 1024)), int(rng.integers(0, 768)))
            frame.sizes[s] = int(rng.integers(0, 16))
            if rng.random() < 0.3:
                frame.new.add(s)
    return frame


@pytest.mark.parametrize("report_id", IR_REPORTS)
def test_fast_encoding_equals_the_encoder(report_id):
    rng = np.random.default_rng(report_id)
    for _ in range(500):
        frame = random_frame(rng)
        buttons = int(rng.integers(0, 1 << 16)) if rng.random() < 0.3 else 0
        accel = (int(rng.integers(0, 1024)), int(rng.integers(0, 1024)), int(rng.integers(0, 1024)))
        zero_missing, zero_first = bool(rng.random() < 0.3), bool(rng.random() < 0.3)
        f = frame_fields(report_id, frame, zero_missing=zero_missing, zero_first=zero_first)
        fast = encode_frame(
            report_id, frame, buttons=buttons, accel=accel, zero_missing=zero_missing, zero_first=zero_first
        )
        plain = encode_ir_report(
            report_id, f.dots, sizes=f.sizes, bboxes=f.bboxes, intensities=f.intensities, buttons=buttons, accel=accel
        )
        assert fast == plain
        assert parse(fast).report_id == report_id


def test_a_value_out_of_its_bits_is_refused_as_by_the_encoder():
    frame = CameraFrame(slots={0: (0, 1500, 10)}, sizes={0: 3})
    with pytest.raises(ProtocolError, match="10 bits"):
        encode_frame(0x33, frame, buttons=0, accel=(512, 512, 512))
    frame = CameraFrame(slots={0: (0, 15, 10)}, sizes={0: 16})
    with pytest.raises(ProtocolError, match="0-15"):
        encode_frame(0x33, frame, buttons=0, accel=(512, 512, 512))


def _observe_plainly(cam: SimulatedCamera, slots: list, t: float) -> CameraFrame:
    """The simulated camera's tracking spelled out with `observe` and `blob_sizes` on arrays."""
    pts = np.asarray(cam.sources(t), dtype=float).reshape(-1, 3)
    frame = CameraFrame()
    uv = cam.camera.observe(pts, cam.rng, sigma_px=cam.sigma_px, dropout=cam.dot_dropout, max_blobs=None)
    sizes = cam.camera.blob_sizes(pts)
    visible = np.isfinite(uv).all(axis=1) & (uv[:, 0] != MISSING) & ~((uv[:, 0] == 0) & (uv[:, 1] == 0))
    for s, src in enumerate(slots):
        if src is not None and (src >= len(visible) or not visible[src]):
            slots[s] = None
    for src in np.flatnonzero(visible):
        if int(src) in slots:
            continue
        if None not in slots:
            break
        s = slots.index(None)
        slots[s] = int(src)
        frame.new.add(s)
    for s, src in enumerate(slots):
        if src is not None:
            frame.slots[s] = (src, int(uv[src, 0]), int(uv[src, 1]))
            frame.sizes[s] = min(max(int(sizes[src]), 0), 15)
    return frame


def test_fast_tracking_equals_the_plain_one():
    # eight sources sweeping across the view and behind the camera: blobs come, go and take slots
    def sources(t: float) -> np.ndarray:
        k = np.arange(8)
        x = 0.4 + 1.5 * np.sin(0.7 * t + 0.4 * k)
        return np.stack([x, 0.4 * np.sin(1.3 * t + 2 * k), 0.3 * np.cos(t + k)], axis=1)

    fast = SimulatedCamera(CAM, sources, np.random.default_rng(3), dot_dropout=0.1)
    plain = SimulatedCamera(CAM, sources, np.random.default_rng(3), dot_dropout=0.1)
    slots: list = [None] * 4
    kinds = set()
    for k in range(1000):
        a, b = fast.observe(0.01 * k), _observe_plainly(plain, slots, 0.01 * k)
        assert (a.slots, a.sizes, a.new) == (b.slots, b.sizes, b.new)
        kinds.add(len(a.slots))
    assert kinds == {0, 1, 2, 3, 4}  # every number of blobs was seen
