"""A simulated person waving a wand in front of a rig of simulated Wiimotes.

`wand_path` is where the wand goes (a `WandPath`: both LEDs every 10 ms, interpolated between; the
running system's simulated world has its remotes look at one: `SimWorld.wave_wand`); `wave_wand`
also observes it with simulated cameras, for the tests and studies that need no HID bytes.

The hand moves between waypoints drawn in the volume the cameras see (each waypoint in the view
of at least two cameras: `wiithrow.vision.rig.points_in_view`), along minimum-jerk segments

    p(s) = p0 + (p1 - p0) (10 s^3 - 15 s^4 + 6 s^5),        s = (t - t0) / T in [0, 1],

whose duration T follows the distance at a hand's pace (`speed_m_s`, 0.25-1.5 s per segment),
with a small tremor on top. The wand turns at the same time: its direction goes from one random
unit vector to the next along the great circle (slerp) with the same s, so it points every way
over a minute; `turn=False` keeps one direction (the degenerate motion a calibration refuses).
The LEDs are the wand's ends, `wand_length_m` apart around the hand.

Each remote sees them as the real camera would (`wiithrow.vision.wiimote.sim_reports.SimulatedCamera`):
0.5 px noise then integer pixels, nothing outside the sensor, random drop-outs, at most four blobs,
and a blob that keeps its slot while visible, a new one taking the lowest free slot (so which slot
holds which LED changes after drop-outs, differently in each camera). The remotes are not
synchronised: remote c reports at phase_c + 10 ms k, and `wiithrow.vision.sync.FrameSynchronizer`
brings them to camera 0's frame times, as it does live. `shuffle=True` also swaps the two dots of
every camera and frame at random, the worst case the method must handle. Optional `stray` IR
sources (a lamp, a window) add dots; a camera that sees more than two dots gives no wand
observation in that frame (`observations.from_dots`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from wiithrow.vision.camera import WiimoteCamera
from wiithrow.vision.errors import VisionError
from wiithrow.vision.rig import points_in_view
from wiithrow.vision.sync import FrameSynchronizer
from wiithrow.vision.wand.observations import WandObservations, from_dots
from wiithrow.vision.wiimote.sim_reports import SLOTS, SimulatedCamera

REPORT_PERIOD_S = 0.01


@dataclass(frozen=True)
class WandTruth:
    """Where the wand's LEDs really were at the observations' frame times: ends (N, 2, 3) (end a
    is the one at +L/2 along the wand's direction; the observations do not know which is which)."""

    t: NDArray[np.float64]
    ends: NDArray[np.float64]


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    out: NDArray[np.float64] = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return out


def hand_path(
    times: NDArray[np.float64],
    waypoints: NDArray[np.float64],
    rng: np.random.Generator,
    *,
    speed_m_s: float = 0.8,
    tremor_m: float = 0.003,
    turn: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The hand's position (N, 3) and the wand's direction (N, 3) at `times` (see the module docstring)."""
    n_way = len(waypoints)
    directions = _unit(rng.normal(size=(n_way, 3))) if turn else np.tile(_unit(rng.normal(size=3)), (n_way, 1))
    durations = np.clip(np.linalg.norm(np.diff(waypoints, axis=0), axis=1) / speed_m_s, 0.25, 1.5)
    starts = np.concatenate([[times[0]], times[0] + np.cumsum(durations)])
    if starts[-1] < times[-1]:
        raise VisionError("hand_path: too few waypoints for the duration")
    seg = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, n_way - 2)
    s = np.clip((times - starts[seg]) / durations[seg], 0.0, 1.0)
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    hand = waypoints[seg] + blend[:, None] * (waypoints[seg + 1] - waypoints[seg])
    phase = rng.uniform(0, 2 * np.pi, 3)
    hand = hand + tremor_m * np.sin(2 * np.pi * 7.0 * times[:, None] + phase)  # a 7 Hz physiological tremor
    d0, d1 = directions[seg], directions[seg + 1]
    d1 = np.where((d0 * d1).sum(axis=1, keepdims=True) < 0, -d1, d1)  # the shorter way round (ends alike)
    angle = np.arccos(np.clip((d0 * d1).sum(axis=1), -1.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.where(angle > 1e-9, np.sin((1 - blend) * angle) / np.sin(angle), 1 - blend)
        w1 = np.where(angle > 1e-9, np.sin(blend * angle) / np.sin(angle), blend)
    return hand, _unit(w0[:, None] * d0 + w1[:, None] * d1)


@dataclass(frozen=True)
class WandPath:
    """Where a waved wand's two LEDs are: `ends` (T, 2, 3) at the times `times` (T,) 10 ms apart,
    linearly interpolated in between (`at`)."""

    times: NDArray[np.float64]
    ends: NDArray[np.float64]

    def at(self, t: float | NDArray[np.float64]) -> NDArray[np.float64]:
        """The ends (2, 3) at time t, or (N, 2, 3) at times (N,)."""
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        flat = self.ends.reshape(len(self.times), 6)
        out = np.stack([np.interp(tt, self.times, flat[:, i]) for i in range(6)], axis=1).reshape(-1, 2, 3)
        return out[0] if np.ndim(t) == 0 else out


def wand_path(
    cameras: Sequence[WiimoteCamera],
    seconds: float,
    rng: np.random.Generator,
    *,
    wand_length_m: float = 0.3,
    depth_m: tuple[float, float] = (0.6, 1.6),
    speed_m_s: float = 0.8,
    turn: bool = True,
) -> WandPath:
    """A person's wand waved for `seconds` (and 10 ms more on each side) in front of `cameras`."""
    n = round(seconds / REPORT_PERIOD_S)
    times = np.arange(-1, n + 2, dtype=np.float64) * REPORT_PERIOD_S
    waypoints = points_in_view(cameras, int(seconds / 0.25) + 3, rng, depth_m=depth_m, margin_px=60.0, min_cameras=2)
    hand, direction = hand_path(times, waypoints, rng, speed_m_s=speed_m_s, turn=turn)
    half = 0.5 * wand_length_m * direction
    return WandPath(times, np.stack([hand + half, hand - half], axis=1))


def wave_wand(
    cameras: Sequence[WiimoteCamera],
    seconds: float,
    rng: np.random.Generator,
    *,
    wand_length_m: float = 0.3,
    sigma_px: float = 0.5,
    dropout: float = 0.01,
    depth_m: tuple[float, float] = (0.6, 1.6),
    speed_m_s: float = 0.8,
    turn: bool = True,
    shuffle: bool = False,
    stray: ArrayLike | None = None,
) -> tuple[WandObservations, WandTruth]:
    """Simulate `seconds` of a wand waved in front of `cameras` (see the module docstring): the
    synchronised observations and the truth at their frame times."""
    path = wand_path(
        cameras, seconds, rng, wand_length_m=wand_length_m, depth_m=depth_m, speed_m_s=speed_m_s, turn=turn
    )
    extra = np.asarray(stray if stray is not None else np.zeros((0, 3)), dtype=float).reshape(-1, 3)

    def sources(t: float) -> NDArray[np.float64]:
        return np.vstack([path.at(t), extra])

    n = round(seconds / REPORT_PERIOD_S)
    phases = np.concatenate([[0.0], rng.uniform(0.0, REPORT_PERIOD_S, len(cameras) - 1)])
    views = [
        SimulatedCamera(
            camera, sources, np.random.default_rng(rng.integers(2**63)), sigma_px=sigma_px, dot_dropout=dropout
        )
        for camera in cameras
    ]
    events = sorted((phases[c] + k * REPORT_PERIOD_S, c) for c in range(len(cameras)) for k in range(n))
    sync = FrameSynchronizer(len(cameras))
    times: list[float] = []
    frames: list[NDArray[np.float64]] = []
    for t, c in events:
        frame = views[c].observe(t)
        dots = np.full((SLOTS, 2), np.nan)
        for slot, (_, u, v) in frame.slots.items():
            dots[slot] = (u, v)
        for synced in sync.push(c, t, dots):
            times.append(synced.t)
            frames.append(synced.dots)
    observations = from_dots(np.asarray(times), np.asarray(frames))
    if shuffle:
        flip = rng.random((observations.cameras, observations.frames)) < 0.5
        pixels = observations.pixels.copy()
        pixels[flip] = pixels[flip][:, ::-1]
        observations = WandObservations(observations.t, pixels, observations.image_size, observations.crowded)
    return observations, WandTruth(observations.t, path.at(observations.t))
