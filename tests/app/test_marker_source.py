"""The marker source (`wiithrow.app.rig`): one event stream with many listeners, options that
survive a restart or a recalibration, the replay as a source that time passes over, and one
report decoder shared by the live driver and the replay."""

import functools

import numpy as np
import pytest

from wiithrow.app.cli.bench.tracking import decoders_and_pipeline, recorded_reports
from wiithrow.app.recording import Recorder, Replay, read_recording
from wiithrow.app.rig.events import CalibrationChanged, Flushed, FramesProcessed, ReportsRead
from wiithrow.app.rig.moving_markers import crossing_paths
from wiithrow.app.rig.pipeline import TrackingPipeline
from wiithrow.app.rig.simulated import simulated_drivers
from wiithrow.app.rig.source import newest_t
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.rig.waiting import pump
from wiithrow.clock import SimClock
from wiithrow.vision.rig import stereo_rig
from wiithrow.vision.sync import FrameSynchronizer
from wiithrow.vision.tracker import MarkerTracker
from wiithrow.vision.wiimote.decoder import ReportDecoder


def test_restart_and_a_recalibration_keep_the_synchroniser_and_tracker_settings():
    Ps = np.stack([c.P for c in stereo_rig()])
    pipeline = TrackingPipeline(
        ["cam0", "cam1"],
        SimClock(),
        synchronizer=functools.partial(FrameSynchronizer, method="nearest", jump_px=30.0, history=4),
        tracker=functools.partial(MarkerTracker, max_markers=2, gate_chi2=9.0),
    )
    for step in (lambda: pipeline.set_calibration(Ps), pipeline.restart, lambda: pipeline.set_calibration(2 * Ps)):
        step()
        sync, tracker = pipeline.sync, pipeline.tracker
        assert (sync.method, sync.jump_px, sync._frames[0].maxlen) == ("nearest", 30.0, 4)
        assert tracker is not None and (tracker.max_markers, tracker.gate_chi2) == (2, 9.0)
    assert pipeline.calibration_revision == 2 and np.array_equal(pipeline.Ps, 2 * Ps)


def test_every_listener_hears_every_event_in_order_and_a_broken_one_breaks_nothing():
    reports, Ps = recorded_reports(0.5, np.random.default_rng(3), 2)
    clock = SimClock()
    decoders, pipeline = decoders_and_pipeline(Ps, clock)
    for c, decoder in enumerate(decoders):
        decoder.subscribe(pipeline.reports_listener(c))
    heard: list[object] = []
    tracked: list[object] = []

    def broken(event: object) -> None:
        raise RuntimeError("a view that fails")

    unsubscribe = pipeline.subscribe(heard.append)
    pipeline.subscribe(broken)
    pipeline.subscribe(lambda e: tracked.extend(e.tracked) if isinstance(e, FramesProcessed | Flushed) else None)
    made = []
    for c, t, data in reports:
        made += pipeline.process(c, decoders[c].decode([(t, data)]))
    made += pipeline.flush(1.0)
    pipeline.set_calibration(Ps)
    kinds = [type(e) for e in heard]
    assert kinds.count(ReportsRead) == kinds.count(FramesProcessed) == len(reports)
    assert kinds[-2:] == [Flushed, CalibrationChanged] and heard[-1].revision == 2
    assert tracked == made and len(made) > 40  # the tracked frames reach every listener, each once
    assert pipeline.events.failures == len(heard)  # the broken one failed every time; tracking went on
    unsubscribe()
    unsubscribe()  # again: nothing happens
    pipeline.flush(2.0)
    assert len(heard) == len(kinds) and len(pipeline.events) == 2


def test_the_decoder_alone_makes_the_frames_the_driver_made_from_the_same_bytes():
    clock = SimClock()
    drivers, _ = simulated_drivers(stereo_rig(), crossing_paths, clock, np.random.default_rng(5))
    driver = drivers[0]
    batches: list[list[tuple[float, bytes]]] = []
    driver.subscribe_reports(batches.append)
    driver.connect()
    live = []
    for _ in range(50):
        clock.advance(0.01)
        live += driver.poll()
    decoder = ReportDecoder(name="again")
    again = [frame for batch in batches for frame in decoder.decode(batch)]
    assert len(live) > 40 and len(again) >= len(live)  # the start-up frames came from acks' waits
    by_seq = {f.seq: f for f in again}
    for frame in live:
        twin = by_seq[frame.seq]
        assert twin.t == frame.t and np.array_equal(twin.dots, frame.dots, equal_nan=True)
    assert decoder.battery == driver.battery is not None and decoder.stats.bad_reports == 0


def test_time_passes_over_a_replay_as_over_a_live_rig(tmp_path):
    clock = SimClock()
    drivers, _ = simulated_drivers(stereo_rig(), crossing_paths, clock, np.random.default_rng(7))
    rig = RigStream(drivers, np.stack([c.P for c in stereo_rig()]))
    recorder = Recorder(tmp_path / "run.mcap", clock)
    recorder.start(rig)
    rig.connect()
    pump(clock, rig, 1.0, step_s=0.005)
    recorder.close()
    live = rig.tracked_since(-np.inf)
    all_at_once = Replay(read_recording(tmp_path / "run.mcap")).run()
    replay = Replay(read_recording(tmp_path / "run.mcap"))
    since = newest_t(replay)
    pump(replay.clock, replay, 0.5, step_s=0.01)
    first_half = replay.tracked_since(since)
    pump(replay.clock, replay, 5.0, step_s=0.01)
    everything = replay.tracked_since(since)
    assert len(live) > 80 and len(all_at_once) == len(live) == len(everything)
    assert 0.3 * len(live) < len(first_half) < 0.7 * len(live)
    for a, b in zip(live, everything):
        assert a.t == b.t and a.ids.tolist() == b.ids.tolist() and np.array_equal(a.position, b.position)
    assert replay.calibration_revision == 1 and replay.calibration_refused() == ""


def test_a_source_with_no_calibration_reads_frames_and_tracks_nothing():
    clock = SimClock()
    drivers, _ = simulated_drivers(stereo_rig(), crossing_paths, clock, np.random.default_rng(9))
    rig = RigStream(drivers)
    rig.connect()
    pump(clock, rig, 0.3)
    assert not rig.calibrated and rig.calibration_revision == 0 and rig.tracked_since(-np.inf) == []
    assert len(rig.synced_since(-np.inf)) > 20 and all(f is not None for f in rig.latest)
    with pytest.raises(ValueError, match="2 drivers for 3 calibrated cameras"):
        rig.set_calibration(np.zeros((3, 3, 4)))
