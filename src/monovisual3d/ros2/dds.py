"""DDS entities as a ROS 2 node makes them (extra ``[ros2]``): the domain, QoS profiles, readers and writers.

The QoS are those ``rmw_cyclonedds_cpp`` sets for the ROS 2 profiles (``create_readwrite_qos`` in its
``rmw_node.cpp``): history, reliability and durability from the profile (transient local with a durability
service of the same history, as Cyclone keeps historical data by it), automatic liveliness, no auto-dispose
of unregistered instances. No data-representation QoS is set: Cyclone then writes plain CDR (XCDR1) for
these ``final`` types, as the ROS 2 middlewares do, and readers accept it.

- :func:`sensor_reader_qos`: best effort, so it matches both reliable (rclpy default) and best-effort
  (``SensorDataQoS``) publishers; a deep history, so samples wait while the node's Python threads are busy.
- :func:`tf_reader_qos` / :func:`tf_static_reader_qos`: tf2's listener QoS (reliable; ``/tf_static``
  transient local, so the static transforms published before the node started arrive too).
- :func:`output_writer_qos`: reliable and transient local with a history of one: a subscriber that starts
  late (RViz, ``ros2 topic echo``) gets the latest estimate at once; it matches volatile subscribers too.

The domain is ``ROS_DOMAIN_ID`` (:func:`domain_id_from_env`, 0 when unset, as ROS 2); the network setup is
Cyclone's own ``CYCLONEDDS_URI``, read by Cyclone when the participant is created.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from .._extras import require
from ..errors import InputError
from .names import dds_topic

_domain = require("cyclonedds.domain", "ros2")
_topic = require("cyclonedds.topic", "ros2")
_pub = require("cyclonedds.pub", "ros2")
_sub = require("cyclonedds.sub", "ros2")
_qos = require("cyclonedds.qos", "ros2")
_util = require("cyclonedds.util", "ros2")

Policy, Qos = _qos.Policy, _qos.Qos

#: Largest DDS domain id of the default port mapping (7400 + 250 * domain must stay below 65536).
MAX_DOMAIN_ID = 232
#: History of the input readers: samples kept while the node's threads are busy (they take them every 0.1 s).
INPUT_HISTORY = 1000
#: History of tf2's ``/tf`` listener and broadcaster (tf2_ros ``DynamicListenerQoS``/``DynamicBroadcasterQoS``).
TF_HISTORY = 100
#: History of the player's publishers (rclpy's default QoS profile: reliable, volatile, keep last 10).
DEFAULT_HISTORY = 10
#: How long a reliable writer may block when the reader's history is full (ROS 2 sets no bound; one second here).
MAX_BLOCKING_S = 1.0


def domain_id_from_env(env: Mapping[str, str] | None = None) -> int:
    """The ROS 2 domain: ``ROS_DOMAIN_ID`` (0 when unset or empty, as ROS 2); InputError if not 0-232.

    Examples
    --------
    >>> domain_id_from_env({"ROS_DOMAIN_ID": "42"})
    42
    """
    text = (os.environ if env is None else env).get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not (text.isascii() and text.isdigit()) or int(text) > MAX_DOMAIN_ID:
        raise InputError(f"ROS_DOMAIN_ID: got {text!r}, expected an integer from 0 to {MAX_DOMAIN_ID}")
    return int(text)


def participant(domain_id: int) -> Any:
    """A DDS participant on ``domain_id`` (Cyclone reads ``CYCLONEDDS_URI`` for its network configuration)."""
    try:
        return _domain.DomainParticipant(domain_id)
    except Exception as exc:  # a bad CYCLONEDDS_URI (file missing, invalid XML) fails here
        raise InputError(f"cannot start DDS on domain {domain_id} ({exc}); check CYCLONEDDS_URI") from None


def _ros_common(history: int, reliable: bool, transient_local: bool) -> list[Any]:
    durability = [Policy.Durability.Volatile]
    if transient_local:
        durability = [
            Policy.Durability.TransientLocal,
            Policy.DurabilityService(
                cleanup_delay=0,
                history=Policy.History.KeepLast(history),
                max_samples=-1,
                max_instances=-1,
                max_samples_per_instance=-1,
            ),
        ]
    reliability = (
        Policy.Reliability.Reliable(max_blocking_time=_util.duration(seconds=MAX_BLOCKING_S))
        if reliable
        else Policy.Reliability.BestEffort
    )
    return [
        Policy.History.KeepLast(history),
        reliability,
        *durability,
        Policy.Liveliness.Automatic(lease_duration=_util.duration(infinite=True)),
        Policy.WriterDataLifecycle(autodispose=False),
    ]


def sensor_reader_qos(reliable: bool = False) -> Any:
    """Detections and camera info: best effort (matches every publisher) unless ``reliable``; volatile."""
    return Qos(*_ros_common(INPUT_HISTORY, reliable, transient_local=False))


def tf_reader_qos() -> Any:
    """``/tf``: reliable, volatile, as tf2's listener (with a deeper history)."""
    return Qos(*_ros_common(INPUT_HISTORY, reliable=True, transient_local=False))


def tf_static_reader_qos() -> Any:
    """``/tf_static``: reliable, transient local (late-joining), as tf2's static listener (with a deeper history)."""
    return Qos(*_ros_common(INPUT_HISTORY, reliable=True, transient_local=True))


def output_writer_qos() -> Any:
    """The node's outputs: reliable, transient local, keep last 1 (a late subscriber gets the latest at once)."""
    return Qos(*_ros_common(1, reliable=True, transient_local=True))


def publisher_qos(kind: str) -> Any:
    """The player's publishers: ``default`` (rclpy's default profile), ``sensor`` (``SensorDataQoS``: best effort,
    keep last 5), ``tf`` (tf2's broadcaster) or ``tf_static`` (tf2's static broadcaster: transient local, keep last 1)."""
    profiles = {
        "default": (DEFAULT_HISTORY, True, False),
        "sensor": (5, False, False),
        "tf": (TF_HISTORY, True, False),
        "tf_static": (1, True, True),
    }
    history, reliable, transient = profiles[kind]
    return Qos(*_ros_common(history, reliable, transient))


class Endpoints:
    """Readers and writers of one participant, by ROS 2 topic name; topics are created once per name.

    Parameters
    ----------
    dp : the DomainParticipant
    """

    def __init__(self, dp: Any) -> None:
        self.participant = dp
        self._topics: dict[str, Any] = {}

    def _topic_for(self, ros_topic: str, msg_class: type) -> Any:
        name = dds_topic(ros_topic)
        topic = self._topics.get(name)
        if topic is None:
            topic = self._topics[name] = _topic.Topic(self.participant, name, msg_class)
        elif topic.data_type is not msg_class:
            raise InputError(
                f"topic {ros_topic}: used with two message types, {topic.data_type.__name__} and {msg_class.__name__}"
            )
        return topic

    def reader(self, ros_topic: str, msg_class: type, qos: Any) -> Any:
        """A DataReader of ``msg_class`` on the ROS 2 topic ``ros_topic`` (its type hash in USER_DATA, as ROS 2 sets it)."""
        return _sub.DataReader(self.participant, self._topic_for(ros_topic, msg_class), qos=_with_type_hash(qos, msg_class))

    def writer(self, ros_topic: str, msg_class: type, qos: Any) -> Any:
        """A DataWriter of ``msg_class`` on the ROS 2 topic ``ros_topic`` (its type hash in USER_DATA, as ROS 2 sets it)."""
        return _pub.DataWriter(self.participant, self._topic_for(ros_topic, msg_class), qos=_with_type_hash(qos, msg_class))


def _with_type_hash(qos: Any, msg_class: type) -> Any:
    from .msgs import user_data

    data = user_data(msg_class)
    return Qos(*qos, Policy.Userdata(data)) if data else qos


__all__ = [
    "Endpoints",
    "domain_id_from_env",
    "output_writer_qos",
    "participant",
    "publisher_qos",
    "sensor_reader_qos",
    "tf_reader_qos",
    "tf_static_reader_qos",
]
