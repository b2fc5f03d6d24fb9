"""`Recorder`: one run written to an MCAP file as it happens, losing at most the last second.

It listens to a local rig's events (`RigStream.subscribe`, `wiithrow.app.rig.events`: the raw
reports its drivers read, each camera's frames processed, each flush, each calibration), so it
sees every raw report with its receive time, every camera frame, every step of the rig and every
tracked frame, in the order they happen; a session adds its arm and throws
(`record_joints`, `record_trajectory`, `record_throw`). Topics and schemas: `channels`.

Losing nothing it had: messages go into compressed chunks that are closed and flushed to the
file at least every second (of the run's clock or of wall time), so a recorder killed with
SIGKILL leaves a file whose complete chunks any MCAP reader reads. A write that fails (a full
disk) or a file that vanished (its folder removed) stops the recording, once, with one line to
`on_error` (stderr by default), and the tracking goes on: the recorder never raises into the rig.

A recording starts from a fresh synchroniser and tracker (`RigStream.restart`: track ids restart
when a recording starts mid-run), the state its replay starts from, so that the replay gives the
recorded markers exactly.
"""

from __future__ import annotations

import functools
import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import msgspec
import numpy as np
from mcap.writer import CompressionType, Writer
from numpy.typing import ArrayLike, NDArray

import wiithrow
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.channels import RecordingError
from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, ReportsRead, RigEvent
from wiithrow.clock import Clock
from wiithrow.listeners import Unsubscribe
from wiithrow.vision.geometry import decompose, quaternion_xyzw
from wiithrow.vision.tracked_frame import TrackedFrame
from wiithrow.vision.wiimote.frames import IRFrame

if TYPE_CHECKING:  # (the tracker: scipy's optimisers and the numba kernels, which a writer process never calls)
    from wiithrow.app.rig.pipeline import TrackingPipeline

FLUSH_EVERY_S = 1.0
SCENE_PERIOD_S = 0.05  # /markers/scene: Foxglove's 3D view of the markers, at 20 Hz
_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
_EMPTY = ("arrows", "cubes", "cylinders", "lines", "triangles", "models", "metadata")
CHUNK_BYTES = 256 * 1024


#: JSON as the messages are written: msgspec's encoder (shortest round-trip floats, as json's), a
#: tenth of json.dumps' cost, which matters at 7 messages per frame.
_encode = msgspec.json.Encoder().encode


def _ns(t: float) -> int:
    return max(0, round(t * 1e9))


def _stderr(message: str) -> None:
    print(f"wiithrow: {message}", file=sys.stderr)


class Recorder:
    """Writes what a rig (and optionally a session) does to `path` (see the module docstring).

    `start(rig)` opens the file and begins; `close()` ends it with MCAP's summary. `error` holds
    the one line that stopped a failed recording (None while all is well)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        clock: Clock,
        *,
        frame_id: str = "link1",
        calibration_text: str | None = None,
        on_error: Callable[[str], object] = _stderr,
        flush_every_s: float = FLUSH_EVERY_S,
        chunk_bytes: int = CHUNK_BYTES,
        extra_metadata: dict[str, str] | None = None,
    ) -> None:
        self.path = Path(path)
        self.clock = clock
        self.frame_id = frame_id
        self.calibration_text = calibration_text
        self.on_error = on_error
        self.flush_every_s = flush_every_s
        self.chunk_bytes = chunk_bytes
        self.extra_metadata = dict(extra_metadata or {})
        self.error: str | None = None
        self.messages = 0
        self._rig: TrackingPipeline | None = None
        self._unsubscribe: Unsubscribe | None = None
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._lock = threading.RLock()
        self._last_flush_wall = 0.0
        self._last_flush_t = 0.0
        self._last_scene = -1e9
        self._unflushed = 0
        self._stop = threading.Event()
        self._flusher: threading.Thread | None = None

    @property
    def active(self) -> bool:
        return self._writer is not None

    # ------------------------------------------------------------------ lifecycle

    def start(self, rig: TrackingPipeline) -> None:
        """Open the file, write the header, the format version and the calibration, and listen to
        `rig`, a local rig (`RigStream`) or a pipeline its decoders' raw reports reach (subscribe
        before `rig.connect()` to keep the remotes' start-up reports too).
        `RecordingError` when the file cannot be created."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb")  # noqa: SIM115 - kept open for the whole run
            writer = Writer(self._file, chunk_size=self.chunk_bytes, compression=CompressionType.ZSTD)
            writer.start(profile=ch.PROFILE, library=f"wiithrow {wiithrow.__version__}")
            metadata = {
                "format_version": str(ch.FORMAT_VERSION),
                "wiithrow_version": wiithrow.__version__,
                "cameras": str(len(rig.camera_names)),
                "frame_id": self.frame_id,
                "clock": type(self.clock).__name__,
                "started_utc": datetime.now(UTC).isoformat(timespec="seconds"),
                **self.extra_metadata,
            }
            writer.add_metadata(ch.METADATA_NAME, metadata | {"digest": ch.digest(metadata)})
            if self.calibration_text is not None:
                t = _ns(self.clock.now())
                writer.add_attachment(
                    t, t, ch.CALIBRATION_ATTACHMENT, "application/json", self.calibration_text.encode()
                )
            self._writer = writer
            self._file.flush()
        except OSError as exc:
            self._close_file()
            raise RecordingError(f"cannot record to {self.path}: {exc.strerror or exc}") from None
        self._last_flush_wall, self._last_flush_t = time.monotonic(), self.clock.now()
        # flushes what waits when nothing new comes (a silent rig): the last second is never held longer
        self._flusher = threading.Thread(target=self._flush_loop, name="wiithrow-recording", daemon=True)
        self._flusher.start()
        self._rig = rig
        with rig.lock:  # between two polls: the file starts from a state a replay starts from
            rig.restart()
            if rig.Ps is not None:
                self.calibrated(rig.Ps)
            self._unsubscribe = rig.subscribe(self._event_of_rig)

    def close(self) -> None:
        """Stop observing and finish the file (its summary and index); harmless when stopped."""
        self._stop.set()
        if self._flusher is not None and self._flusher is not threading.current_thread():
            self._flusher.join(timeout=2.0)
        self._detach()
        with self._lock:
            writer, self._writer = self._writer, None
            if writer is not None:
                try:
                    writer.finish()
                except (OSError, ValueError) as exc:
                    self._report(f"recording stopped: cannot finish {self.path}: {exc}")
            self._close_file()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _detach(self, *, wait_for_rig: bool = True) -> None:
        """Stop observing: between two polls, or at once after a failure (which may come from
        another thread holding this recorder's lock: waiting for the rig could deadlock, and
        without a writer a call in flight writes nothing)."""
        rig, self._rig = self._rig, None
        unsubscribe, self._unsubscribe = self._unsubscribe, None
        if rig is not None and unsubscribe is not None:
            if wait_for_rig:
                rig.lock.acquire()
            try:
                unsubscribe()
            finally:
                if wait_for_rig:
                    rig.lock.release()

    def _close_file(self) -> None:
        f, self._file = self._file, None
        if f is not None:
            try:
                f.close()
            except OSError:
                pass

    # ------------------------------------------------------------------ what the rig tells

    def _event_of_rig(self, event: RigEvent) -> None:
        """One event of the rig (called under its lock, in order; never raises: see `_write`)."""
        if isinstance(event, ReportsRead):
            self.reports(event.camera, event.batch)
        elif isinstance(event, FramesProcessed):
            self.processed(event.camera, event.frames, event.tracked)
        elif isinstance(event, Flushed):
            self.flushed(event.now, event.synced, event.tracked)
        elif isinstance(event, CalibrationChanged):
            self.calibrated(event.Ps)

    def reports(self, camera: int, batch: Sequence[tuple[float, bytes]]) -> None:
        self._write(
            ch.reports_topic(camera),
            batch[-1][0],
            {"camera": camera, "t": [t for t, _ in batch], "data": [d.hex() for _, d in batch]},
        )

    def processed(self, camera: int, frames: Sequence[IRFrame], tracked: Sequence[TrackedFrame]) -> None:
        if not frames:
            return
        with self._lock:
            topic = ch.dots_topic(camera)
            for f in frames:
                dots = [None if u != u or v != v else [u, v] for u, v in f.dots.tolist()]
                self._write(
                    topic, f.t, {"camera": camera, "t": f.t, "t_device": f.t_device, "seq": f.seq, "dots": dots}
                )
            self._write(ch.STEPS, frames[-1].t, {"step": "process", "camera": camera, "frames": len(frames)})
            self._markers(tracked)

    def flushed(self, now: float, synced: int, tracked: Sequence[TrackedFrame]) -> None:
        if not synced:
            return
        with self._lock:
            self._write(ch.STEPS, now, {"step": "flush", "camera": -1, "frames": synced, "t": now})
            self._markers(tracked)

    def calibrated(self, Ps: NDArray[np.float64]) -> None:
        t = self.clock.now()
        with self._lock:
            self._write(ch.CALIBRATION, t, {"frame_id": self.frame_id, "Ps": np.asarray(Ps).tolist()})
            self._write(ch.TF, t, {"transforms": camera_transforms(Ps, self.frame_id, t)})

    def _markers(self, tracked: Sequence[TrackedFrame]) -> None:
        if tracked and tracked[-1].t - self._last_scene >= SCENE_PERIOD_S:
            self._last_scene = tracked[-1].t
            self._scene(tracked[-1])
        for f in tracked:
            self._write(
                ch.MARKERS,
                f.t,
                {
                    "t": f.t,
                    "frame_id": self.frame_id,
                    "ids": f.ids.tolist(),
                    "positions": f.position.tolist(),
                    "visible": f.visible.tolist(),
                    "views": f.n_views.tolist(),
                },
            )

    def _scene(self, f: TrackedFrame) -> None:
        """The markers as a Foxglove SceneUpdate: a 3 cm sphere per marker (grey while predicted)
        and its id above it, replaced by the next update."""
        stamp = {"sec": _ns(f.t) // 1_000_000_000, "nsec": _ns(f.t) % 1_000_000_000}
        spheres, texts = [], []
        for i, (x, y, z), seen in zip(f.ids.tolist(), f.position.tolist(), f.visible.tolist()):
            color = {"r": 1.0, "g": 0.3, "b": 0.1, "a": 1.0} if seen else {"r": 0.6, "g": 0.6, "b": 0.6, "a": 0.6}
            spheres.append(
                {
                    "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": _IDENTITY},
                    "size": {"x": 0.03, "y": 0.03, "z": 0.03},
                    "color": color,
                }
            )
            texts.append(
                {
                    "pose": {"position": {"x": x, "y": y, "z": z + 0.04}, "orientation": _IDENTITY},
                    "billboard": True,
                    "font_size": 14.0,
                    "scale_invariant": True,
                    "color": color,
                    "text": str(i),
                }
            )
        entity = {
            "timestamp": stamp,
            "frame_id": self.frame_id,
            "id": "markers",
            "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": False,
            "spheres": spheres,
            "texts": texts,
            **{k: [] for k in _EMPTY},
        }
        self._write(ch.MARKERS_SCENE, f.t, {"deletions": [], "entities": [entity]})

    def mark_start(self, t: float) -> None:
        """The command started tracking at `t` (the rig's clock): `/rig/start`, what a replay's
        rows count their `t` from."""
        self._write(ch.TRACKING_START, t, {"t": t})

    # ------------------------------------------------------------------ what a session tells

    def record_joints(self, t: float, q: ArrayLike, dq: ArrayLike) -> None:
        self._write(ch.JOINTS, t, {"t": t, "q": np.asarray(q, float).tolist(), "dq": np.asarray(dq, float).tolist()})

    def record_trajectory(self, t: float, times: ArrayLike, q: ArrayLike, what: str) -> None:
        self._write(
            ch.TRAJECTORY,
            t,
            {"t": t, "times": np.asarray(times, float).tolist(), "q": np.asarray(q, float).tolist(), "what": what},
        )

    def record_throw(self, t: float, record: dict[str, Any]) -> None:
        self._write(ch.THROWS, t, {"t": t, "record": record})

    def record_transforms(self, t: float, transforms: list[dict[str, Any]]) -> None:
        self._write(ch.TF, t, {"transforms": transforms})

    # ------------------------------------------------------------------ writing

    def _write(self, topic: str, t: float, message: dict[str, Any]) -> None:
        with self._lock:
            writer = self._writer
            if writer is None:
                return
            try:
                channel = self._channels.get(topic)
                if channel is None:
                    channel = self._channel(writer, topic)
                data = _encode(message)
                log_time = _ns(t)
                writer.add_message(channel, log_time, data, log_time, self.messages)
                self.messages += 1
                self._unflushed += 1
                wall = time.monotonic()
                if wall - self._last_flush_wall >= self.flush_every_s or t - self._last_flush_t >= self.flush_every_s:
                    self._flush(writer, wall, t)
            except (OSError, ValueError, TypeError) as exc:  # never into the rig: the recording stops
                self._fail(exc)

    def _channel(self, writer: Writer, topic: str) -> int:
        name = ch.schema_of(topic)
        schema = self._schemas.get(name)
        if schema is None:
            schema = self._schemas[name] = writer.register_schema(name, "jsonschema", ch.schema_bytes(name))
        channel = self._channels[topic] = writer.register_channel(topic, "json", schema)
        return channel

    def _flush_loop(self) -> None:
        while not self._stop.wait(self.flush_every_s / 2):
            with self._lock:
                writer = self._writer
                if writer is None:
                    return
                wall = time.monotonic()
                if self._unflushed and wall - self._last_flush_wall >= self.flush_every_s:
                    try:
                        self._flush(writer, wall, self._last_flush_t)
                    except Exception as exc:  # a full disk, a vanished file, or a bug: one line, tracking goes on
                        self._fail(exc)

    def _flush(self, writer: Writer, wall: float, t: float) -> None:
        """Close the chunk and hand it to the OS; check that the file is still there."""
        writer.flush()
        self._unflushed = 0
        self._last_flush_wall, self._last_flush_t = wall, t
        if self._file is not None and os.fstat(self._file.fileno()).st_nlink == 0:
            raise OSError(f"{self.path} vanished (its folder was removed or the file deleted)")

    def _fail(self, exc: Exception) -> None:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc) or type(exc).__name__
        self._writer = None
        self._detach(wait_for_rig=False)
        self._close_file()
        self._report(f"recording stopped: cannot write {self.path}: {reason}; tracking goes on")

    def _report(self, message: str) -> None:
        self.error = message
        try:
            self.on_error(message)
        except Exception:
            pass


def frame_transform(T: NDArray[np.float64], parent: str, child: str, t: float) -> dict[str, Any]:
    """A `foxglove.FrameTransform` message: the 4x4 pose `T` of `child` in `parent` at time `t` (s)."""
    x, y, z, w = quaternion_xyzw(T[:3, :3])
    return {
        "timestamp": {"sec": _ns(t) // 1_000_000_000, "nsec": _ns(t) % 1_000_000_000},
        "parent_frame_id": parent,
        "child_frame_id": child,
        "translation": dict(zip("xyz", T[:3, 3].tolist())),
        "rotation": {"x": x, "y": y, "z": z, "w": w},
    }


def camera_transforms(Ps: NDArray[np.float64], frame_id: str, t: float) -> list[dict[str, Any]]:
    """Each camera's pose in `frame_id` as Foxglove FrameTransforms (child `camera_c`, z forward)."""
    stamp = {"sec": int(_ns(t) // 1_000_000_000), "nsec": int(_ns(t) % 1_000_000_000)}
    Ps = np.ascontiguousarray(Ps, dtype=np.float64)
    return [
        {
            "timestamp": stamp,
            "parent_frame_id": frame_id,
            "child_frame_id": f"camera_{c}",
            "translation": dict(translation),
            "rotation": dict(rotation),
        }
        for c, (translation, rotation) in enumerate(_camera_poses(Ps.tobytes(), Ps.shape[0]))
    ]


@functools.lru_cache(maxsize=8)
def _camera_poses(Ps_bytes: bytes, count: int) -> tuple[tuple[tuple[tuple[str, float], ...], ...], ...]:
    """Each camera's (translation, rotation) items: its centre and the quaternion of R^T (camera ->
    frame), computed once per calibration (a decomposition costs about 0.2 ms a camera; the
    session's recorder writes these frames at 50 Hz in the rig's thread)."""
    out = []
    for P in np.frombuffer(Ps_bytes, dtype=np.float64).reshape(count, 3, 4):
        d = decompose(P)
        x, y, z, w = quaternion_xyzw(d.R.T)
        cx, cy, cz = d.center.tolist()
        out.append(((("x", cx), ("y", cy), ("z", cz)), (("x", x), ("y", y), ("z", z), ("w", w))))
    return tuple(out)
