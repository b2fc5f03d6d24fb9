"""A throw's error is the rig's 3D landing against the target, along / across / total, and a steady
sideways miss is learned away: in the developers' test world (the kinematic world with the ball
released 15 mm beside the throw plane, `noise.release_across_m`), the reported error follows the
simulation's truth, the sideways part included, and 10 measured throws that join the library
take the miss away (the shipped library has no sideways labels: it starts with no correction);
a library trained in that world learns it from its own labels. An error of the throw plane's
(x, z) alone read 2.4 mm there for a true 15.0 mm (median of 20 throws), and without a learned
sideways term the true error stayed 15.1 mm after 10 measured throws."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
from mcap.reader import make_reader

from wiithrow.app.channels.json_schemas import SCHEMAS
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.session import Session, ThrowRecord, simulated_session
from wiithrow.app.settings import Settings
from wiithrow.app.studies.compensation import random_targets
from wiithrow.app.throws.training import train_in_world
from wiithrow.throwing import Area, Generalizer

BIAS_M = 0.015


def biased(across_m: float = BIAS_M) -> Settings:
    settings = Settings()
    return settings.replace(noise=dataclasses.replace(settings.noise, release_across_m=across_m))


def throw_at(session: Session, targets: np.ndarray) -> list[ThrowRecord]:
    records = []
    for target in targets:
        session.set_target(target)
        assert session.align().converged
        records.append(session.throw(session.plan_preview().id))
    return records


def totals(records: list[ThrowRecord]) -> tuple[np.ndarray, np.ndarray]:
    """(reported, true) totals (m)."""
    return np.array([r.error.total_m for r in records]), np.array([r.true_error.total_m for r in records])


def test_a_steady_sideways_miss_is_reported_as_it_is_and_learned_away_within_10_throws():
    session = simulated_session(seed=0, settings=biased(), calibration="true", quiet=True)
    probes = random_targets(12, np.random.default_rng(1))
    session.set_learning(False)
    before = throw_at(session, probes)
    reported, true = totals(before)
    across = np.array([r.error.across_m for r in before])
    true_across = np.array([r.true_error.across_m for r in before])
    print(
        f"\nbiased 15 mm, no learning: reported median {1e3 * np.median(reported):.1f} mm "
        f"(across {1e3 * np.median(across):+.1f}), true {1e3 * np.median(true):.1f} mm "
        f"(across {1e3 * np.median(true_across):+.1f}); largest |reported - true| {1e3 * np.max(np.abs(reported - true)):.1f} mm"
    )
    # the miss is there, and the rig reports it: the sideways part throw by throw, the total in the median
    assert np.median(true) > 0.012 and np.median(true_across) > 0.012
    assert np.max(np.abs(across - true_across)) < 0.002
    assert abs(np.median(reported) - np.median(true)) < 0.002 and np.median(np.abs(reported - true)) < 0.002
    assert all(r.error_m == r.error.total_m and r.true_error_m == r.true_error.total_m for r in before)

    session.set_learning(True)
    learning = throw_at(session, random_targets(10, np.random.default_rng(2)))
    assert all(r.learned is not None and "error" not in r.learned for r in learning)
    session.set_learning(False)
    after = throw_at(session, probes)
    reported_after, true_after = totals(after)
    aimed = [r.learned["learned_across_offset_m"] for r in learning]
    print(
        f"after 10 measured throws: true median {1e3 * np.median(true_after):.1f} mm, reported "
        f"{1e3 * np.median(reported_after):.1f} mm; learned offset {1e3 * aimed[-1]:+.1f} mm"
    )
    assert np.median(true_after) < 0.008 and abs(aimed[-1] - BIAS_M) < 0.004
    assert abs(np.median(reported_after) - np.median(true_after)) < 0.002
    session.close()


def test_a_library_trained_in_the_biased_world_learns_the_miss_from_its_labels():
    session = simulated_session(seed=1, settings=biased(), calibration="true", quiet=True, learn=False)
    world = session.world
    library = train_in_world(world, np.random.default_rng(3))  # the paper's 25 throws
    labels = library.across
    assert np.isfinite(labels).all() and abs(np.median(labels) - BIAS_M) < 0.002, labels
    fitted = Generalizer(library).across((1.3, 0.2))
    assert abs(fitted - BIAS_M) < 0.002
    session.use_library(library)
    records = throw_at(session, random_targets(10, np.random.default_rng(4)))
    _, true = totals(records)
    across = np.array([r.true_error.across_m for r in records])
    print(
        f"\ntrained in the biased world: learned offset {1e3 * fitted:+.1f} mm, true median {1e3 * np.median(true):.1f} mm "
        f"(across {1e3 * np.median(across):+.1f} mm)"
    )
    assert np.median(true) < 0.008
    assert all(abs(r.error.across_m) < 0.006 for r in records)
    session.close()


def test_the_3d_error_is_in_the_record_the_json_and_the_recording(tmp_path):
    session = simulated_session(seed=5, settings=biased(), calibration="true", quiet=True, learn=False)
    path = tmp_path / "session.mcap"
    recorder = SessionRecorder(session, path)
    recorder.begin()
    (record,) = throw_at(session, random_targets(1, np.random.default_rng(6)))
    recorder.close()
    outcome = json.loads(json.dumps(record.to_dict()))
    assert set(outcome["error"]) == {"along_m", "across_m", "height_m", "total_m"}
    assert outcome["error"]["total_m"] == outcome["error_m"] and abs(outcome["error"]["across_m"] - BIAS_M) < 0.002
    assert abs(outcome["true_error"]["across_m"] - BIAS_M) < 0.002
    assert abs(outcome["landing_measured_across_throw_plane_m"] - BIAS_M) < 0.002
    with path.open("rb") as f:
        throws = [json.loads(m.data) for _, c, m in make_reader(f).iter_messages() if c.topic == "/throws"]
    assert throws[-1]["record"]["outcome"]["error"] == outcome["error"]
    schema = SCHEMAS["wiithrow.Throw"]["properties"]["record"]["properties"]["outcome"]["properties"]
    assert set(schema["error"]["properties"]) == {"along_m", "across_m", "height_m", "total_m"}
    # measured again (the operator's Measure landing): the same 3D error, within the rig's noise
    again = session.measure_landing()
    assert abs(again.error.across_m - record.error.across_m) < 0.001
    assert abs(again.error.total_m - record.error.total_m) < 0.002
    session.close()


def test_the_dashboards_training_labels_each_landing_in_its_throws_plane(tmp_path):
    """The first training throw starts where the arm is (joint 1 turned 0.15 rad to a target) and
    its landing is measured once the arm is home: its label is taken into the plane it was thrown
    in, the sideways miss with it (the measured x at home taken as the label is 13 mm short,
    about 1.35 (1 - cos 0.15) m, and its 0.2 m to the side of home's plane is lost)."""
    session = simulated_session(seed=2, settings=biased(), calibration="true", quiet=True, learn=False)
    session.set_target(np.array([1.3 * np.cos(0.15), 1.3 * np.sin(0.15), 0.0]))
    assert session.align().converged and abs(session.world.arm.state().q[0] - 0.15) < 0.01
    session.train_to(tmp_path / "trained.json")
    session.start_training(Area((1.2, 1.5), (0.0, 0.3)), 5)
    for _ in range(5):
        session.training_throw(session.preview_training_throw().id)
        session.measure_training_landing()
    run = session.snapshot().training
    assert run is not None and run.complete
    first = run.throws[0]
    assert first.q1 is not None and abs(first.q1 - 0.15) < 0.01  # thrown with joint 1 where the alignment left it
    misses = [np.hypot(*(t.measured - t.target)) for t in run.throws]
    across = [t.measured_across for t in run.throws]
    assert max(misses) < 0.01, misses  # in the plane: millimetres from each target
    # the 15 mm beside each throw's plane, give or take the throw's own scatter (joint 1's 1 mrad tracking)
    assert all(a is not None and abs(a - BIAS_M) < 0.005 for a in across) and abs(np.median(across) - BIAS_M) < 0.002
    session.finish_training(use="always")  # put in use, as the operator chooses after Finish
    np.testing.assert_allclose(session.library.across, across)
    session.close()
