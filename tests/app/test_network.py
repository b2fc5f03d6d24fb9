"""Zenoh publishing (wiithrow.app.network): the payloads read back, and a session's rig and throws
reach a subscriber on loopback (explicit endpoints, no multicast scouting: no network needed)."""

import json
import time

import numpy as np
import pytest

from wiithrow.app.cli.bench.publish import free_port, loopback_configs
from wiithrow.app.cli.publishing import Publishing
from wiithrow.app.errors import AppError
from wiithrow.app.network.messages import dots_key, markers_key, markers_message, rig_name, tracked_frame
from wiithrow.app.network.subscriber import Subscription
from wiithrow.app.network.zenoh_session import open_session
from wiithrow.app.session import demo_target_base, simulated_session
from wiithrow.vision.tracked_frame import TrackedFrame


def test_a_markers_payload_reads_back_as_the_frame():
    rng = np.random.default_rng(0)
    frame = TrackedFrame(
        t=1.25,
        ids=np.array([3, 7]),
        position=rng.normal(size=(2, 3)),
        velocity=rng.normal(size=(2, 3)),
        filtered=rng.normal(size=(2, 3)),
        visible=np.array([True, False]),
        n_views=np.array([2, 0]),
    )
    message = json.loads(markers_message("lab", 4, frame, "link1", sent=100.0))
    assert message["schema"] == 1 and message["seq"] == 4 and message["rig"] == "lab" and message["sent"] == 100.0
    back = tracked_frame(message)
    assert back.t == 1.25 and back.ids.tolist() == [3, 7] and back.visible.tolist() == [True, False]
    assert np.abs(back.position - frame.position).max() < 1e-6  # rounded to the micrometre
    assert back.n_views.tolist() == [2, 0]


def test_rig_names_and_keys():
    assert markers_key("lab-1") == "wiithrow/lab-1/markers"
    assert dots_key("rig", "cam 0/x") == "wiithrow/rig/cameras/cam_0_x/dots"
    for bad in ("a/b", "*", "", "a b", "$x"):
        with pytest.raises(AppError):
            rig_name(bad)


def test_a_bad_config_is_one_line(tmp_path):
    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: 'nonsense' }")
    with pytest.raises(AppError) as err:
        open_session(bad)
    assert "\n" not in str(err.value) and "nonsense" in str(err.value) and ".rs:" not in str(err.value)
    with pytest.raises(AppError, match="no Zenoh configuration file"):
        open_session(tmp_path / "missing.json5")


def _drain(subscription, until, timeout_s=5.0):
    got = []
    end = time.monotonic() + timeout_s
    while not until(got) and time.monotonic() < end:
        sample = subscription.get(0.05)
        if sample is not None:
            got.append(sample)
    return got


def test_a_session_publishes_every_tracked_frame_in_order_and_its_throws(tmp_path):
    listen_cfg, connect_cfg = loopback_configs(tmp_path, free_port())
    subscriber_session = open_session(listen_cfg)
    session = simulated_session(seed=0, calibration="true", quiet=True)
    try:
        subscription = Subscription(subscriber_session, "wiithrow/lab/**")
        args = type("Args", (), {"zenoh_config": str(connect_cfg), "rig_name": "lab", "wait_subscriber": 10.0})()
        publishing = Publishing(args, "test", session.world.rig.camera_names, "link1", session.world.clock)
        assert publishing.publisher.has_subscribers()
        publishing.watch(session)
        session.set_target(demo_target_base())
        assert session.align().converged
        record = session.throw(session.plan_preview().id)
        publishing.close()
        published = publishing.publisher.markers_sent
        assert published > 100  # the alignment and the throw tracked for seconds at 100 Hz
        got = _drain(
            subscription,
            lambda g: sum(s.key.endswith("/markers") for s in g) >= published and any("throws" in s.key for s in g),
        )
    finally:
        session.close()
        subscriber_session.close()
    markers = [s.decode() for s in got if s.key == "wiithrow/lab/markers"]
    assert [m["seq"] for m in markers] == list(range(published))  # every frame, in order
    assert all(np.diff([m["t"] for m in markers]) > 0)
    assert {len(m["markers"]) for m in markers[-10:]} >= {1}  # the target (and the landing marker) tracked
    throws = [s.decode() for s in got if s.key == "wiithrow/lab/throws"]
    assert len(throws) == 1 and throws[0]["index"] == record.index
    assert throws[0]["result"]["error_m"] == pytest.approx(record.error_m)
    dots = [s for s in got if "/cameras/" in s.key]
    assert {s.key for s in dots} == {"wiithrow/lab/cameras/cam0/dots", "wiithrow/lab/cameras/cam1/dots"}
