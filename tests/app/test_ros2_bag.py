"""Recordings ROS 2 can play (issue 44): a simulated session recorded, then `wiithrow export`ed, is a
bag that ROS 2's readers we did not write open and decode, every message of every ROS 2 channel:
rosbags (its `AnyReader`, its own CDR and its own ROS 2 Humble definitions, the oracle: each
message re-encoded by it is our bytes, and our `.msg` texts are its), and the MCAP project's
`mcap-ros2-support` decoder; the recording itself still replays and keeps its JSON channels."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability, QosReliability
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from tests.helpers.sim_fixtures import target_at
from wiithrow.app.channels import registry as r
from wiithrow.app.channels.ros2_definitions import DEFINITIONS, full_text
from wiithrow.app.cli.main import main
from wiithrow.app.recording import replay_markers
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.session import simulated_session

NAMESPACE = "/wiithrow"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Path, Path, dict]:
    """A session recorded (its rig, an alignment, a previewed and executed throw) and exported."""
    folder = tmp_path_factory.mktemp("bag")
    session = simulated_session(seed=5, calibration="true", quiet=True)
    path, bag = folder / "session.mcap", folder / "session.ros2.mcap"
    recorder = SessionRecorder(session, path)
    recorder.begin()
    session.set_target(target_at(1.3, 0.35, 0.1))
    assert session.align().converged
    session.throw(session.plan_preview().id)
    recorder.close()
    facts = {"names": list(session.world.arm_model.joint_names), "cameras": list(session.world.rig.camera_names)}
    session.close()
    assert main(["export", str(path), str(bag)]) == 0
    return path, bag, facts


def _recorded_json(path: Path) -> dict[str, list[tuple[int, dict]]]:
    out: dict[str, list[tuple[int, dict]]] = {}
    with path.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
            out.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    return out


def _expected_topics(facts: dict) -> dict[str, tuple[str, str]]:
    """ROS 2 topic -> (its type, the recording's topic) for every ROS 2 form of every channel."""
    expected = {}
    for channel in r.CHANNELS:
        cameras = range(len(facts["cameras"])) if channel.per_camera else [None]
        for form in channel.ros2:
            for c in cameras:
                name = form.topic if c is None else form.topic.format(name=facts["cameras"][c])
                topic = name if name.startswith("/") else f"{NAMESPACE}/{name}"
                expected[topic] = (form.type, channel.topic_of(c))
    return expected


def test_rosbags_opens_the_bag_and_decodes_every_message_of_every_ros2_channel_as_its_own_cdr(recorded):
    path, bag, facts = recorded
    recording = _recorded_json(path)
    expected = _expected_topics(facts)
    humble = get_typestore(Stores.ROS2_HUMBLE)
    decoded: dict[str, list] = {}
    with AnyReader([bag]) as reader:
        assert reader.is2
        connections = {c.topic: c for c in reader.connections}
        assert set(connections) == set(expected)  # every ROS 2 channel of the session, and no other
        for topic, (kind, source) in expected.items():
            connection = connections[topic]
            assert connection.msgtype == kind and connection.ext.serialization_format == "cdr"
            assert connection.msgcount == len(recording[source]) > 0, topic  # every message
            (qos,) = connection.ext.offered_qos_profiles
            form = next(f for f in r.channel_of(source).ros2 if f.type == kind)
            assert qos.durability == (
                QosDurability.TRANSIENT_LOCAL if form.qos.transient_local else QosDurability.VOLATILE
            )
            assert qos.reliability == (QosReliability.RELIABLE if form.qos.reliable else QosReliability.BEST_EFFORT)
        for connection, log_time, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            decoded.setdefault(connection.topic, []).append((log_time, message))
            if connection.msgtype in humble.fielddefs:  # rosbags' own encoding of what it decoded: our bytes
                assert bytes(humble.serialize_cdr(message, connection.msgtype)) == raw, connection.topic
    assert {topic: len(messages) for topic, messages in decoded.items()} == {
        t: connections[t].msgcount for t in expected
    }

    markers = decoded[f"{NAMESPACE}/markers"]
    for (log_time, message), (recorded_time, json_message) in zip(markers, recording["/markers"]):
        assert log_time == recorded_time and message.header.stamp.sec * 10**9 + message.header.stamp.nanosec == log_time
        assert [m.marker_index for m in message.markers] == json_message["ids"]
        got = [[m.translation.x, m.translation.y, m.translation.z] for m in message.markers]
        assert got == json_message["positions"]  # float64 on the wire: exact
    assert [m.frame_number for _, m in markers] == list(range(len(markers)))
    joints = decoded[f"{NAMESPACE}/joint_states"]
    for (_, message), (_, json_message) in zip(joints, recording["/arm/joints"]):
        assert list(message.name) == facts["names"] and message.position.tolist() == json_message["q"]
    (static,) = [m for _, m in decoded["/tf_static"]]
    assert [t.child_frame_id for t in static.transforms] == [f"camera_{c}" for c in range(len(facts["cameras"]))]
    assert {(t.header.frame_id, t.child_frame_id) for _, m in decoded["/tf"] for t in m.transforms} == {
        ("base", "link1")
    }
    (trajectory,) = [m for _, m in decoded[f"{NAMESPACE}/arm/trajectory"]]
    assert list(trajectory.joint_names) == facts["names"] and len(trajectory.points) > 10
    (throw,) = [m for _, m in decoded[f"{NAMESPACE}/throws"]]
    assert json.loads(throw.data) == recording["/throws"][-1][1]["record"]
    (description,) = [m for _, m in decoded[f"{NAMESPACE}/robot_description"]]
    assert "<robot" in description.data


def test_our_message_definitions_are_ros2_humble_s_field_for_field(recorded):
    """rosbags' ROS 2 Humble store is the reference: each of our `.msg` texts parses to its fields
    (mocap4r2_msgs, in no distribution, is checked against its IDL by the DDS tests)."""
    humble = get_typestore(Stores.ROS2_HUMBLE)
    for short in DEFINITIONS:
        package, name = short.split("/")
        full = f"{package}/msg/{name}"
        if package == "mocap4r2_msgs":
            continue
        ours = get_types_from_msg(DEFINITIONS[short], full)[full]
        assert ours == humble.fielddefs[full], full
    _, bag, _ = recorded
    with bag.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.schemas
    for schema in summary.schemas.values():  # each schema the complete definition rosbag2 stores
        assert schema.encoding == "ros2msg" and schema.data.decode() == full_text(schema.name)
        assert "MSG: std_msgs/Header" in schema.data.decode() or "Header" not in schema.data.decode()


def test_mcap_ros2_support_decodes_the_bag_too(recorded):
    from mcap_ros2.decoder import DecoderFactory

    path, bag, facts = recorded
    recording = _recorded_json(path)
    counts: dict[str, int] = {}
    with bag.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for _, channel, _, message in reader.iter_decoded_messages(log_time_order=False):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/tf_static":
                assert message.transforms[0].header.frame_id == "link1"
    assert counts == {topic: len(recording[source]) for topic, (_, source) in _expected_topics(facts).items()}


def test_the_recording_itself_still_replays_and_keeps_its_json_channels(recorded):
    path, _, _ = recorded
    recording = _recorded_json(path)
    replay, frames = replay_markers(path)
    assert replay.end is None and len(frames) == len(recording["/markers"]) > 100
    assert all(m["positions"] == f.position.tolist() for (_, m), f in zip(recording["/markers"], frames))
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and {c.message_encoding for c in summary.channels.values()} == {"json"}
    assert np.isfinite([m["t"] for _, m in recording["/markers"]]).all()
