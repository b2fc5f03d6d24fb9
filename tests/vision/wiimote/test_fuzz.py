"""Fuzzing: `parse` lets only ProtocolError escape, and the driver's read loop survives garbage."""

from __future__ import annotations

import numpy as np

from wiithrow.clock import SimClock
from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.wiimote import input_reports, protocol
from wiithrow.vision.wiimote.device import WiimoteDriver
from wiithrow.vision.wiimote.driver_settings import DriverSettings, DriverState
from wiithrow.vision.wiimote.simulator import SimulatedWiimote

N_INPUTS = 120_000


def real_reports(rng: np.random.Generator) -> list[bytes]:
    """Valid reports of every input id, with random content."""
    out = []
    for _ in range(50):
        dots = {s: (int(rng.integers(0, 1024)), int(rng.integers(0, 1024))) for s in range(4) if rng.random() < 0.7}
        sizes = {s: int(rng.integers(0, 16)) for s in dots}
        bboxes = {s: tuple(int(v) for v in rng.integers(0, 128, 4)) for s in dots}
        inten = {s: int(rng.integers(0, 256)) for s in dots}
        btn = int(rng.integers(0, 0x10000))
        acc = tuple(int(v) for v in rng.integers(0, 1024, 3))
        for rid in (0x33, 0x36, 0x37, 0x3E, 0x3F):
            out.append(
                input_reports.encode_ir_report(
                    rid, dots, sizes=sizes, bboxes=bboxes, intensities=inten, buttons=btn, accel=acc
                )
            )
        out.append(input_reports.encode_status(btn, int(rng.integers(0, 256)), int(rng.integers(0, 256))))
        out.append(input_reports.encode_ack(int(rng.integers(0, 256)), int(rng.integers(0, 256)), buttons=btn))
        out.append(input_reports.encode_read_reply(int(rng.integers(0, 1 << 24)), rng.bytes(int(rng.integers(1, 17)))))
        for rid in (0x30, 0x31, 0x32, 0x34, 0x35, 0x3D):
            out.append(bytes([rid]) + rng.bytes(protocol.INPUT_LENGTHS[rid] - 1))
    return out


def fuzz_inputs(rng: np.random.Generator, n: int):
    reals = real_reports(rng)
    known = np.array(sorted(protocol.INPUT_LENGTHS), dtype=np.uint8)
    for i in range(n):
        kind = i % 5
        if kind == 0:  # random bytes, random length
            yield rng.bytes(int(rng.integers(0, 40)))
        elif kind == 1:  # a known id with random bytes of a random length
            yield bytes([int(rng.choice(known))]) + rng.bytes(int(rng.integers(0, 30)))
        elif kind == 2:  # truncated real report
            r = reals[int(rng.integers(0, len(reals)))]
            yield r[: int(rng.integers(0, len(r) + 1))]
        elif kind == 3:  # mutated real report (bytes flipped, maybe padded or extended)
            r = bytearray(reals[int(rng.integers(0, len(reals)))])
            for _ in range(int(rng.integers(1, 4))):
                r[int(rng.integers(0, len(r)))] = int(rng.integers(0, 256))
            if rng.random() < 0.3:
                r += rng.bytes(int(rng.integers(1, 8)))
            yield bytes(r)
        else:  # hidapi-style list of ints, sometimes out of range
            r = list(reals[int(rng.integers(0, len(reals)))])
            if rng.random() < 0.2:
                r[int(rng.integers(0, len(r)))] = int(rng.integers(-5, 300))
            yield r


def test_parse_only_ever_raises_protocol_error():
    rng = np.random.default_rng(20240611)
    ok = bad = 0
    kinds: dict[str, int] = {}
    for data in fuzz_inputs(rng, N_INPUTS):
        try:
            rep = input_reports.parse(data)
        except protocol.ProtocolError:
            bad += 1
            continue
        # anything that parses is well formed
        ok += 1
        kinds[type(rep).__name__] = kinds.get(type(rep).__name__, 0) + 1
        assert isinstance(rep, input_reports.Report) and 0 <= int(rep.buttons) <= 0xFFFF
        if isinstance(rep, input_reports.IRReport):
            assert set(rep.dots) <= set(rep.slots)
            assert all(0 <= x <= 1022 and 0 <= y <= 767 and (x, y) != (0, 0) for x, y in rep.dots.values())
            assert all(0 <= s <= 15 for s in rep.sizes.values())
    assert ok + bad == N_INPUTS
    assert ok > 20_000 and bad > 40_000  # both paths were exercised
    assert set(kinds) == {"IRReport", "StatusReport", "Ack", "ReadReply", "DataReport"}


class ChaosTransport:
    """The simulated remote, with garbage mixed into everything it says."""

    def __init__(self, sim: SimulatedWiimote, rng: np.random.Generator, p_garbage: float) -> None:
        self.sim, self.rng, self.p = sim, rng, p_garbage
        self.garbage_sent = 0
        self._gen = fuzz_inputs(np.random.default_rng(int(rng.integers(1 << 31))), 10**9)

    def open(self) -> None:
        self.sim.open()

    def close(self) -> None:
        self.sim.close()

    def write(self, data: bytes) -> int:
        return self.sim.write(data)

    def read(self, max_size: int, timeout_ms: int) -> bytes:
        if self.rng.random() < self.p:
            self.garbage_sent += 1
            g = next(self._gen)
            return bytes(v & 0xFF for v in g) or b"\x00"
        return self.sim.read(max_size, timeout_ms)


def test_driver_read_loop_survives_garbage():
    clock = SimClock(5.0)
    cam = WiimoteCamera.at([0, 0, 0], [1, 0, 0])
    pts = np.array([[1.0, 0.1, 0.05], [1.5, -0.2, 0.1]])
    sim = SimulatedWiimote(cam, lambda t: pts, clock, np.random.default_rng(1), sigma_px=0.0)
    chaos = ChaosTransport(sim, np.random.default_rng(2), p_garbage=0.0)
    drv = WiimoteDriver(chaos, clock, DriverSettings(write_retries=5))
    drv.connect()
    chaos.p = 0.5  # now half of everything read is garbage (including plausible-looking reports)
    truth = {tuple(p) for p in np.rint(cam.project(pts)).astype(int)}
    frames = []
    for _ in range(3000):
        clock.advance(0.01)
        frames += drv.poll()
    assert chaos.garbage_sent > 3000
    assert drv.stats.bad_reports > 1000 and drv.stats.loop_errors == 0
    assert drv.state is DriverState.STREAMING
    assert len(frames) > 2500
    # garbage that happens to parse as an IR report yields odd frames; the real ones are all there
    clean = [f for f in frames if {tuple(int(v) for v in d) for d in f.dots[f.visible]} == truth]
    assert len(clean) >= sim.stats.data_reports - 5
    for f in frames:
        d = f.dots[f.visible]
        assert np.all((d[:, 0] >= 0) & (d[:, 0] <= 1022) & (d[:, 1] >= 0) & (d[:, 1] <= 767))
