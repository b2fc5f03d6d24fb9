"""ROS 2 on the wire (issue 24): what a session publishes reaches a subscriber in another process
whose types come from the shipped IDL only, field by field; the CDR bytes of each message type
match references written from the CDR rules."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from wiithrow.app.channels.json_messages import camera_transforms
from wiithrow.app.cli.ros2_flags import Ros2Publishing
from wiithrow.app.session import demo_target_base, simulated_session

ROOT = Path(__file__).resolve().parents[2]


def _domain() -> int:
    """A domain id of this test run's own (tests in parallel, other people's ROS 2 on this host)."""
    return 100 + os.getpid() % 100


def _subscriber(domain: int, namespace: str, cameras: list[str]) -> subprocess.Popen[str]:
    command = [sys.executable, "-m", "tests.helpers.ros2_subscriber", str(domain), namespace, ",".join(cameras), "120"]
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    child = subprocess.Popen(
        command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT
    )
    assert child.stdout is not None
    ready = json.loads(child.stdout.readline() or "{}")
    assert "ready" in ready, child.stderr.read() if child.stderr else ""
    return child


def test_a_session_reaches_a_ros2_subscriber_built_from_the_idl_field_by_field():
    namespace = f"/t{uuid.uuid4().hex[:8]}"
    domain = _domain()
    session = simulated_session(seed=0, calibration="true", quiet=True)
    rig = session.world.rig
    child = _subscriber(domain, namespace, list(rig.camera_names))
    tracked, throws = [], []
    try:
        args = type("Args", (), {"ros2_domain": str(domain), "ros2_namespace": namespace, "ros2_config": None})()
        world = session.world
        publishing = Ros2Publishing(
            args, "test", rig.camera_names, "link1", world.clock, joint_names=world.arm_model.joint_names
        )
        publisher = publishing.publisher
        assert publisher.wait_for_subscribers(20.0)
        unsubscribe = rig.subscribe(lambda e: tracked.extend(getattr(e, "tracked", ())))
        publishing.watch(session)
        session.set_target(demo_target_base())
        assert session.align().converged
        throws.append(session.throw(session.plan_preview().id))
        publishing.close()
        unsubscribe()
        out, _ = child.communicate("", timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
        session.close()
    samples = [json.loads(line) for line in out.splitlines()]
    by_topic: dict[str, list[dict]] = {}
    for s in samples:
        by_topic.setdefault(s["topic"], []).append(s["sample"])

    markers = by_topic[f"rt{namespace}/markers"]
    assert publisher.markers_sent > 100 and len(tracked) == publisher.markers_sent
    assert [m["frame_number"] for m in markers] == list(range(publisher.markers_sent))  # every frame, in order
    for message, frame in zip(markers, tracked):
        assert message["header"]["frame_id"] == "link1"
        assert [m["marker_index"] for m in message["markers"]] == frame.ids.tolist()
        assert [m["id_type"] for m in message["markers"]] == [1] * len(frame.ids)  # USE_INDEX
        got = np.array([[m["translation"][k] for k in "xyz"] for m in message["markers"]]).reshape(-1, 3)
        np.testing.assert_array_equal(got, frame.position.reshape(-1, 3))  # float64 on the wire: exact

    views = by_topic[f"rt{namespace}/markers/visualization"]
    assert len(views) == publisher.markers_sent
    for message, frame in zip(views, tracked):
        assert message["markers"][0]["action"] == 3  # DELETEALL first
        spheres = [m for m in message["markers"] if m["ns"] == "wiithrow/markers" and m["type"] == 2]
        assert [m["id"] for m in spheres] == frame.ids.tolist()
        for sphere, p, seen in zip(spheres, frame.position, frame.visible):
            assert [sphere["pose"]["position"][k] for k in "xyz"] == p.tolist()
            assert sphere["color"]["r"] == (1.0 if seen else pytest.approx(0.6))
        labels = [m["text"] for m in message["markers"] if m["ns"] == "wiithrow/ids"]
        assert labels == [str(i) for i in frame.ids.tolist()]

    statics = by_topic["rt/tf_static"]  # at start, and at each calibration since
    assert len(statics) >= 1
    static = statics[-1]
    assert [t["child_frame_id"] for t in static["transforms"]] == [f"camera_{c}" for c in range(len(rig.camera_names))]
    for t, pose in zip(static["transforms"], camera_transforms(rig.Ps, "link1", 0)):
        assert t["header"]["frame_id"] == "link1"
        assert t["transform"]["translation"] == pose["translation"]
        assert t["transform"]["rotation"] == pose["rotation"]
    tf = by_topic["rt/tf"]
    assert len(tf) == publisher.arm_sent > 10
    q1 = [
        2
        * np.arctan2(t["transforms"][0]["transform"]["rotation"]["z"], t["transforms"][0]["transform"]["rotation"]["w"])
        for t in tf
    ]
    assert all(
        t["transforms"][0]["header"]["frame_id"] == "base" and t["transforms"][0]["child_frame_id"] == "link1"
        for t in tf
    )
    assert abs(q1[-1] - q1[0]) > 0.05  # joint 1 turned to the target, and /tf followed it

    (thrown,) = by_topic[f"rt{namespace}/throws"]
    document = json.loads(thrown["data"])  # the throw's document, as a recording's /throws has it
    assert document["index"] == throws[0].index
    assert document["outcome"]["error_m"] == pytest.approx(throws[0].error_m)
    # the 3D error (along / across / height / total) and the simulation's true one, as the record says
    outcome = json.loads(json.dumps(throws[0].to_dict()))
    assert set(document["outcome"]["error"]) == {"along_m", "across_m", "height_m", "total_m"}
    assert document["outcome"]["error"] == outcome["error"]
    assert document["outcome"]["true_error"] == outcome["true_error"]

    joints = by_topic[f"rt{namespace}/joint_states"]
    assert len(joints) == len(tf)  # a sample: base -> link1 and the joints, stamped alike
    names = list(session.world.arm_model.joint_names)
    assert all(j["name"] == names and len(j["position"]) == len(j["velocity"]) == len(names) for j in joints)
    assert [j["header"]["stamp"] for j in joints] == [t["transforms"][0]["header"]["stamp"] for t in tf]
    (trajectory,) = by_topic[f"rt{namespace}/arm/trajectory"]  # the previewed throw's
    assert trajectory["joint_names"] == names and len(trajectory["points"]) > 10
    (description,) = by_topic[f"rt{namespace}/robot_description"]
    assert "<robot" in description["data"]

    for c, name in enumerate(rig.camera_names):
        dots = by_topic[f"rt{namespace}/cameras/{name}/dots"]
        assert len(dots) == publisher.dots_sent[c] > 100
        assert all(d["header"]["frame_id"] == f"camera_{c}" and d["channels"][0]["name"] == "slot" for d in dots)
        assert all(len(d["points"]) == len(d["channels"][0]["values"]) <= 4 for d in dots)


def test_a_subscriber_that_comes_later_gets_the_cameras_and_the_robot_description():
    """Transient local, as ROS 2's conventions have it (tf2's static broadcaster, robot_state_publisher):
    a reader that matches after /tf_static and robot_description were written still gets them."""
    from wiithrow.app.channels import registry as r
    from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher
    from wiithrow.app.settings import Settings
    from wiithrow.app.worlds import nominal_cameras
    from wiithrow.clock import SimClock

    namespace = f"/t{uuid.uuid4().hex[:8]}"
    domain = _domain()
    Ps = np.stack([c.P for c in nominal_cameras(Settings().with_cameras(2).rig)])
    urdf = (ROOT / "robot" / "urdf" / "pa10.urdf").read_text()
    publisher = Ros2ProcessPublisher(domain, ["cam0", "cam1"], "link1", clock=SimClock(), namespace=namespace)
    try:
        publisher.publish_calibration(Ps)
        publisher.post(r.ROBOT_DESCRIPTION.topic, 0, {"data": urdf})
        end = time.monotonic() + 30.0
        while publisher.messages_sent < 1 and time.monotonic() < end:  # handed to the writer process
            time.sleep(0.01)
        assert publisher.flush(30.0)
        time.sleep(0.5)  # written: nobody reads them yet
        child = _subscriber(domain, namespace, ["cam0", "cam1"])  # and now a reader comes
        assert child.stdout is not None and child.stdin is not None
        by_topic: dict[str, list[dict]] = {}
        wanted = {"rt/tf_static", f"rt{namespace}/robot_description"}
        while not wanted <= set(by_topic) and (line := child.stdout.readline()):  # (it ends by itself in 120 s)
            sample = json.loads(line)
            by_topic.setdefault(sample["topic"], []).append(sample["sample"])
        child.stdin.close()
        child.wait(60)
    finally:
        publisher.close()
    (static,) = by_topic["rt/tf_static"]
    assert [t["child_frame_id"] for t in static["transforms"]] == ["camera_0", "camera_1"]
    (description,) = by_topic[f"rt{namespace}/robot_description"]
    assert description["data"] == urdf
