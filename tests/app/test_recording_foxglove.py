"""Recordings Foxglove opens (issue 24): every channel of a session's recording has a message
encoding and schema encoding Foxglove reads without a plugin (json + jsonschema), every message
is valid against its channel's schema, and the channels meant for Foxglove's panels carry
Foxglove's schema names with fields that foxglove-sdk's own message classes accept; the raw HID
reports and wiithrow's channels are kept beside them."""

from __future__ import annotations

import json

import foxglove.messages as fm
import jsonschema
from foxglove.messages import Duration, Timestamp
from mcap.reader import make_reader

from tests.helpers.sim_fixtures import target_at
from wiithrow.app.recording import channels as ch
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.app.session import simulated_session

#: Foxglove's readable encodings (docs: "MCAP: supported message and schema encodings").
READABLE = {
    ("json", "jsonschema"),
    ("protobuf", "protobuf"),
    ("cdr", "ros2msg"),
    ("cdr", "ros2idl"),
    ("ros1", "ros1msg"),
}
FOXGLOVE_PANELS = {
    ch.TF: "foxglove.FrameTransforms",
    ch.TF_STATIC: "foxglove.FrameTransforms",
    ch.MARKERS_SCENE: "foxglove.SceneUpdate",
    ch.ROBOT_DESCRIPTION: "std_msgs/msg/String",  # what Foxglove's URDF layer reads from a topic
}


def _vector(d):
    return fm.Vector3(**d)


def _pose(d):
    return fm.Pose(position=_vector(d["position"]), orientation=fm.Quaternion(**d["orientation"]))


def _frame_transforms(message) -> fm.FrameTransforms:
    """The message as foxglove-sdk's FrameTransforms (a field it does not know raises TypeError)."""
    return fm.FrameTransforms(
        transforms=[
            fm.FrameTransform(
                **{
                    **t,
                    "timestamp": Timestamp(**t["timestamp"]),
                    "translation": _vector(t["translation"]),
                    "rotation": fm.Quaternion(**t["rotation"]),
                }
            )
            for t in message["transforms"]
        ]
    )


def _scene_update(message) -> fm.SceneUpdate:
    entities = []
    for e in message["entities"]:
        spheres = [
            fm.SpherePrimitive(pose=_pose(s["pose"]), size=_vector(s["size"]), color=fm.Color(**s["color"]))
            for s in e["spheres"]
        ]
        texts = [
            fm.TextPrimitive(**{**t, "pose": _pose(t["pose"]), "color": fm.Color(**t["color"])}) for t in e["texts"]
        ]
        empty = {k: v for k, v in e.items() if isinstance(v, list) and k not in ("spheres", "texts")}
        assert all(v == [] for v in empty.values())
        entities.append(
            fm.SceneEntity(
                **{
                    k: v
                    for k, v in e.items()
                    if k not in ("spheres", "texts", "timestamp", "lifetime") and k not in empty
                },
                timestamp=Timestamp(**e["timestamp"]),
                lifetime=Duration(**e["lifetime"]),
                spheres=spheres,
                texts=texts,
                **{k: [] for k in empty},
            )
        )
    return fm.SceneUpdate(deletions=[], entities=entities)


def test_every_channel_of_a_session_recording_is_one_foxglove_reads(tmp_path):
    session = simulated_session(seed=5, calibration="true", quiet=True)
    path = tmp_path / "session.mcap"
    recorder = SessionRecorder(session, path)
    recorder.begin()
    session.set_target(target_at(1.3, 0.35, 0.1))
    assert session.align().converged
    session.throw(session.plan_preview().id)
    recorder.close()
    session.close()
    by_topic = _check_channels(path)
    assert {ch.reports_topic(0), ch.dots_topic(0), ch.STEPS, ch.MARKERS, ch.CALIBRATION, ch.JOINTS, ch.THROWS} <= set(
        by_topic
    )
    assert set(FOXGLOVE_PANELS) <= set(by_topic)
    for message in by_topic[ch.TF] + by_topic[ch.TF_STATIC]:
        assert _frame_transforms(message).encode()  # foxglove-sdk's own FrameTransforms takes every field
    for message in by_topic[ch.MARKERS_SCENE]:
        assert _scene_update(message).encode()


def test_every_channel_of_a_track_recording_is_one_foxglove_reads(tmp_path):
    from wiithrow.app.cli.main import main

    path = tmp_path / "run.mcap"
    assert main(["track", "--sim", "--duration", "0.5", "--record", str(path), "--out", str(tmp_path / "rows")]) == 0
    by_topic = _check_channels(path)
    assert {ch.TRACKING_START, ch.MARKERS, ch.MARKERS_SCENE, ch.TF_STATIC} <= set(by_topic)


def _check_channels(path) -> dict[str, list[dict]]:
    """Each channel's encodings, schema and messages checked (the test's docstring); the messages by topic."""
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        channels, schemas = summary.channels, summary.schemas
        by_topic: dict[str, list[dict]] = {}
        for _, channel, message in reader.iter_messages(log_time_order=False):
            by_topic.setdefault(channel.topic, []).append(json.loads(message.data))
    for channel in channels.values():
        schema = schemas[channel.schema_id]
        assert (channel.message_encoding, schema.encoding) in READABLE, channel.topic
        document = json.loads(schema.data)
        jsonschema.Draft7Validator.check_schema(document)
        assert document["title"] == schema.name == ch.schema_of(channel.topic)
        validator = jsonschema.Draft7Validator(document)
        for message in by_topic[channel.topic][:50]:
            validator.validate(message)
        if channel.topic in FOXGLOVE_PANELS:
            assert schema.name == FOXGLOVE_PANELS[channel.topic]
        else:
            assert schema.name.startswith("wiithrow.")  # our own channels, kept
    return by_topic
