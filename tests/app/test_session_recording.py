"""A session recorded to MCAP (issue 14, part A): the arm's joints and URDF, the frames base ->
link1 (`/tf`) and link1 -> cameras (`/tf_static`), a previewed throw's trajectory and the throw,
besides the rig; read with the `mcap` package's own reader; the markers replay exactly."""

import json

import numpy as np
from mcap.reader import make_reader

from tests.helpers.sim_fixtures import target_at
from wiithrow.app.recording import replay_markers
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.session import simulated_session


def test_a_recorded_throw(tmp_path):
    session = simulated_session(seed=5, calibration="true", quiet=True)
    path = tmp_path / "session.mcap"
    recorder = SessionRecorder(session, path)
    recorder.begin()
    session.set_target(target_at(1.3, 0.35, 0.1))
    assert session.align().converged
    preview = session.plan_preview()
    record = session.throw(preview.id)
    recorder.close()
    session.close()
    messages: dict[str, list[dict]] = {}
    with path.open("rb") as f:
        reader = make_reader(f)
        attachments = [a.name for a in reader.iter_attachments()]
        for _, channel, message in reader.iter_messages(log_time_order=False):
            messages.setdefault(channel.topic, []).append(json.loads(message.data))
    assert attachments == ["calibration.json"]
    assert {"/arm/joints", "/arm/trajectory", "/throws", "/tf", "/tf_static", "/markers", "/wiimote/0/reports"} <= set(
        messages
    )
    joints = messages["/arm/joints"]
    assert len(joints) > 50 and all(
        len(j["q"]) == 7 and j["names"] == list(session.world.arm_model.joint_names) for j in joints
    )
    assert abs(max(j["q"][0] for j in joints) - 0.35) < 0.02  # joint 1 turned to the target
    frames = {(t["parent_frame_id"], t["child_frame_id"]) for m in messages["/tf"] for t in m["transforms"]}
    assert frames == {("base", "link1")}  # what moves; the cameras stand
    statics = {(t["parent_frame_id"], t["child_frame_id"]) for m in messages["/tf_static"] for t in m["transforms"]}
    assert statics == {("link1", "camera_0"), ("link1", "camera_1")}
    (description,) = messages["/robot_description"]
    assert description["data"].lstrip().startswith("<?xml") or "<robot" in description["data"]
    trajectory = messages["/arm/trajectory"][0]
    assert len(trajectory["times"]) == len(trajectory["q"]) > 10
    throw = messages["/throws"][-1]["record"]
    assert throw["outcome"]["error_m"] == record.error_m and len(throw["release"]["q"]) == 7
    assert np.isfinite(throw["release"]["position_base_m"]).all()
    replay, replayed = replay_markers(path)
    assert replay.end is None and len(replayed) == len(messages["/markers"])
    assert all(m["positions"] == f.position.tolist() for m, f in zip(messages["/markers"], replayed))
