"""ROS 2 names on DDS: the mapping every DDS-based ROS 2 middleware uses."""

from __future__ import annotations

import pytest

from monovisual3d.errors import InputError
from monovisual3d.ros2.names import absolute_topic, dds_topic, dds_type, prefixed, ros_topic, ros_type


@pytest.mark.parametrize(
    ("ros", "dds"),
    [("/detections", "rt/detections"), ("/camera/camera_info", "rt/camera/camera_info"), ("tf_static", "rt/tf_static")],
)
def test_topics(ros: str, dds: str) -> None:
    assert dds_topic(ros) == dds
    assert ros_topic(dds) == absolute_topic(ros)


@pytest.mark.parametrize(
    ("ros", "dds"),
    [
        ("std_msgs/msg/String", "std_msgs::msg::dds_::String_"),
        ("vision_msgs/msg/Detection2DArray", "vision_msgs::msg::dds_::Detection2DArray_"),
        ("tf2_msgs/msg/TFMessage", "tf2_msgs::msg::dds_::TFMessage_"),
    ],
)
def test_types(ros: str, dds: str) -> None:
    assert dds_type(ros) == dds
    assert ros_type(dds) == ros


def test_prefix() -> None:
    assert prefixed("/fruit", "detections") == "/fruit/detections"
    assert prefixed("robot1/fruit", "status") == "/robot1/fruit/status"


@pytest.mark.parametrize("bad", ["", "/", "/a//b", "/a/", "/1abc", "/a b", "/a-b"])
def test_bad_topic_names(bad: str) -> None:
    with pytest.raises(InputError, match=r"^--detections: got .*, expected a ROS 2 topic name"):
        absolute_topic(bad, "--detections")


def test_bad_type_and_dds_names() -> None:
    with pytest.raises(InputError, match="expected pkg/msg/Name"):
        dds_type("std_msgs/String")
    with pytest.raises(InputError, match="is not a ROS 2 topic"):
        ros_topic("detections")
    with pytest.raises(InputError, match="is not a ROS 2 message type"):
        ros_type("std_msgs::msg::String")
