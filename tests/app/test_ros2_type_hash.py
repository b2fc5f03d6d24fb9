"""The type hashes in our writers' USER_DATA are ROS 2's: for every message type we publish (and
every type it refers to), `type_hash` equals rosbags' RIHS01 of the Jazzy definitions (mocap4r2's
from its upstream .msg text); for `rmw_dds_common` (whose Gid is a `.msg` char array, an IDL uint8
array to rosidl) it equals the hashes rosidl generated for Jazzy."""

from __future__ import annotations

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from wiithrow.app.ros2 import discovery
from wiithrow.app.ros2 import messages as m
from wiithrow.app.ros2.type_hash import ros_type_name, type_description, type_hash

#: MOCAP4ROS2-Project/mocap4r2_msgs (rolling), msg/Marker.msg and msg/Markers.msg, constants left out.
MOCAP4R2_MSGS = {
    "mocap4r2_msgs/msg/Marker": "int8 id_type\nint32 marker_index\nstring marker_name\ngeometry_msgs/Point translation\n",
    "mocap4r2_msgs/msg/Markers": "std_msgs/Header header\nuint32 frame_number\nmocap4r2_msgs/Marker[] markers\n",
}
#: rosidl_generator_c's hashes of rmw_dds_common (Jazzy), from a generated `*__description.c`.
RMW_DDS_COMMON_JAZZY = {
    discovery.Gid: "RIHS01_ab6f21cfbb0a6dbb837161e1110c2051a2850ed9f9c53944d7115d9bcebedf71",
    discovery.NodeEntitiesInfo: "RIHS01_8ffef65ee2d088c63b1e8fcd31e800ba9fc8dbe0ee15ca60d1676de5218087a7",
    discovery.ParticipantEntitiesInfo: "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e",
}
#: Every type a channel is published as (`messages.BY_TYPE`: markers, marker array, point cloud, tf,
#: joint states, trajectory, string).
PUBLISHED = list(m.BY_TYPE.values())


def jazzy_store():
    store = get_typestore(Stores.ROS2_JAZZY)
    for name, text in MOCAP4R2_MSGS.items():
        store.register(get_types_from_msg(text, name))
    return store


@pytest.mark.parametrize("kind", PUBLISHED, ids=lambda k: ros_type_name(k))
def test_every_published_type_and_what_it_refers_to_hashes_as_rosidl(kind):
    store = jazzy_store()
    names = [ros_type_name(kind)] + [d["type_name"] for d in type_description(kind)["referenced_type_descriptions"]]
    classes = {ros_type_name(kind): kind}
    for name in names[1:]:  # the referenced types' own hashes, from their classes in `messages`
        classes[name] = next(c for c in vars(m).values() if isinstance(c, type) and _named(c, name))
    for name in names:
        assert type_hash(classes[name]) == store.hash_rihs01(name), name
    print(f"{ros_type_name(kind)}: {type_hash(kind)} ({len(names) - 1} referenced types, each equal)")


def _named(kind: type, name: str) -> bool:
    try:
        return ros_type_name(kind) == name
    except (AttributeError, ValueError):
        return False


def test_the_discovery_messages_hash_as_rosidl_generated_them_for_jazzy():
    for kind, expected in RMW_DDS_COMMON_JAZZY.items():
        assert type_hash(kind) == expected, ros_type_name(kind)
    # rosbags' own store reads the .msg char as char (13): its hash is not rosidl's; read as uint8 it is
    store = get_typestore(Stores.ROS2_JAZZY)
    assert store.hash_rihs01("rmw_dds_common/msg/ParticipantEntitiesInfo") != type_hash(
        discovery.ParticipantEntitiesInfo
    )
    idl = get_typestore(Stores.EMPTY)
    idl.register(get_types_from_msg("uint8[16] data", "rmw_dds_common/msg/Gid"))
    for name in ("NodeEntitiesInfo", "ParticipantEntitiesInfo"):
        idl.register({f"rmw_dds_common/msg/{name}": store.fielddefs[f"rmw_dds_common/msg/{name}"]})
    assert (
        idl.hash_rihs01("rmw_dds_common/msg/ParticipantEntitiesInfo")
        == RMW_DDS_COMMON_JAZZY[discovery.ParticipantEntitiesInfo]
    )
