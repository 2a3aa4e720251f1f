"""The ROS 2 message definitions marknav ships, against the Jazzy types ``rosbags`` knows."""

from __future__ import annotations

import pytest

from marknav.runs.records.mcap_recording import TOPICS
from marknav.runs.records.ros2_types import MSG_DIR, SEPARATOR, definition, dependencies

rosbags = pytest.importorskip("rosbags")

SHIPPED = sorted(f"{p.parent.parent.name}/msg/{p.stem}" for p in MSG_DIR.glob("*/msg/*.msg"))
#: The ROS 2 core interfaces (Jazzy's typestore has them; foxglove_msgs is not among them: the
#: recording test decodes its annotations from the definitions stored in the file).
CORE = [n for n in SHIPPED if not n.startswith("foxglove_msgs/")]


@pytest.mark.parametrize("name", CORE)
def test_each_definition_has_the_fields_and_constants_of_ros2_jazzy(name: str) -> None:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    jazzy = get_typestore(Stores.ROS2_JAZZY)
    ours = get_types_from_msg(definition(name).split(SEPARATOR)[0], name)
    assert ours[name] == jazzy.fielddefs[name]


def test_a_definition_lists_each_dependency_once_after_the_type_itself() -> None:
    text = definition("visualization_msgs/msg/MarkerArray")
    parts = text.split(SEPARATOR + "\n")
    assert parts[0] == "visualization_msgs/Marker[] markers\n"
    named = [p.splitlines()[0] for p in parts[1:]]
    assert named[0] == "MSG: visualization_msgs/Marker"
    assert len(named) == len(set(named))
    assert "MSG: builtin_interfaces/Time" in named and "MSG: sensor_msgs/CompressedImage" in named
    assert dependencies("std_msgs/msg/String") == []


def test_every_topic_type_is_shipped_and_round_trips_through_rosbags() -> None:
    from rosbags.typesys import Stores, get_typestore

    from marknav.runs.records.ros2_types import encoder

    jazzy = get_typestore(Stores.ROS2_JAZZY)
    for type_name, _ in TOPICS.values():
        assert type_name in SHIPPED
    data = encoder("nav_msgs/msg/Odometry")({
        "header": {"stamp": {"sec": 12, "nanosec": 5}, "frame_id": "odom"},
        "child_frame_id": "base_link",
        "pose": {"pose": {"position": {"x": 1.5, "y": -2.0, "z": 0.0}}}})
    msg = jazzy.deserialize_cdr(data, "nav_msgs/msg/Odometry")
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (12, 5)
    assert msg.header.frame_id == "odom" and msg.child_frame_id == "base_link"
    assert (msg.pose.pose.position.x, msg.pose.pose.position.y) == (1.5, -2.0)
    assert msg.pose.pose.orientation.w == 1.0  # the definition's default
