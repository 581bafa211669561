"""ROS 2 names on DDS: topics ``/x`` -> ``rt/x``, types ``pkg/msg/Name`` -> ``pkg::msg::dds_::Name_``.

This is the mapping every DDS-based ROS 2 middleware uses (``rmw_cyclonedds_cpp``, ``rmw_fastrtps_cpp``,
``rmw_connextdds``): a node that names its DDS topics and types this way is seen by ``ros2 topic list`` and
matches rclpy and rclcpp publishers and subscriptions. Pure string functions, no DDS import.
"""

from __future__ import annotations

import re

from ..errors import InputError

#: Prefix of ROS 2 topics on DDS (``rt`` = ROS topic; services use ``rq``/``rr``).
TOPIC_PREFIX = "rt"

#: A ROS 2 topic name: ``/`` separated tokens of letters, digits and underscores, not starting with a digit,
#: no ``//`` and no trailing ``/`` (relative names are made absolute by :func:`absolute_topic`).
_TOPIC = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")
#: A ROS 2 message type name ``pkg/msg/Name``.
_TYPE = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/msg/([A-Za-z][A-Za-z0-9_]*)$")


def absolute_topic(name: str, what: str = "topic") -> str:
    """``name`` as an absolute ROS 2 topic (``x/y`` -> ``/x/y``); InputError ``WHAT: ...`` if it is not a valid name.

    Examples
    --------
    >>> absolute_topic("camera/camera_info")
    '/camera/camera_info'
    """
    text = str(name).strip()
    full = text if text.startswith("/") else "/" + text
    if not _TOPIC.match(full):
        raise InputError(
            f"{what}: got {text!r}, expected a ROS 2 topic name such as /camera/camera_info "
            "(letters, digits and underscores between slashes, no token starting with a digit)"
        )
    return full


def dds_topic(ros_topic: str) -> str:
    """The DDS topic of a ROS 2 topic: ``/fruit/detections`` -> ``rt/fruit/detections``.

    Examples
    --------
    >>> dds_topic("/tf_static")
    'rt/tf_static'
    """
    return TOPIC_PREFIX + absolute_topic(ros_topic)


def ros_topic(dds_name: str) -> str:
    """The ROS 2 topic of a DDS topic (inverse of :func:`dds_topic`); InputError if it is not a ROS topic."""
    if not dds_name.startswith(TOPIC_PREFIX + "/"):
        raise InputError(f"DDS topic {dds_name!r} is not a ROS 2 topic (no {TOPIC_PREFIX}/ prefix)")
    return absolute_topic(dds_name[len(TOPIC_PREFIX) :])


def dds_type(ros_type: str) -> str:
    """The DDS type name of a ROS 2 message type: ``std_msgs/msg/String`` -> ``std_msgs::msg::dds_::String_``.

    Examples
    --------
    >>> dds_type("vision_msgs/msg/Detection2DArray")
    'vision_msgs::msg::dds_::Detection2DArray_'
    """
    m = _TYPE.match(ros_type)
    if not m:
        raise InputError(f"message type: got {ros_type!r}, expected pkg/msg/Name")
    return f"{m.group(1)}::msg::dds_::{m.group(2)}_"


def ros_type(dds_name: str) -> str:
    """The ROS 2 message type of a DDS type name (inverse of :func:`dds_type`)."""
    m = re.match(r"^([A-Za-z][A-Za-z0-9_]*)::msg::dds_::([A-Za-z][A-Za-z0-9_]*)_$", dds_name)
    if not m:
        raise InputError(f"DDS type {dds_name!r} is not a ROS 2 message type (pkg::msg::dds_::Name_)")
    return f"{m.group(1)}/msg/{m.group(2)}"


def prefixed(prefix: str, name: str) -> str:
    """An output topic under ``prefix``: ``prefixed("/fruit", "detections")`` -> ``/fruit/detections``.

    Examples
    --------
    >>> prefixed("/robot1/fruit", "markers")
    '/robot1/fruit/markers'
    """
    base = absolute_topic(prefix, "--prefix")
    return absolute_topic(f"{base}/{name}")


__all__ = ["TOPIC_PREFIX", "absolute_topic", "dds_topic", "dds_type", "prefixed", "ros_topic", "ros_type"]
