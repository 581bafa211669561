"""ROS messages -> library objects: stamps, transforms, detections (and the vision_msgs definitions).

One home for reading ROS message fields, used by the bag importer (:mod:`.rosbag`, on ``rosbags`` objects)
and the live node (:mod:`monovisual3d.ros2`, on its own DDS message classes). Every function reads fields by
name, so any object with the ROS field names works: ``rosbags`` messages, rclpy messages, the node's
``cyclonedds`` classes, or ``types.SimpleNamespace``. The camera of a ``sensor_msgs/CameraInfo`` is
:func:`monovisual3d.io.calibration_ros.camera_from_camera_info`.

The vision_msgs layouts differ: ROS 1 (noetic) has ``bbox.center`` as ``geometry_msgs/Pose2D``
(``x, y, theta``) and hypotheses ``id, score``; ROS 2 Humble and later (vision_msgs 4.x) have
``vision_msgs/Pose2D`` (``position.x, position.y, theta``) and ``hypothesis.class_id, hypothesis.score``.
Both are read. :data:`VISION_MSGS_ROS1` and :data:`VISION_MSGS_ROS2` hold their ``.msg`` definitions (for
``rosbags.typesys.get_types_from_msg``) where a bag or a test needs them; ROS 2's include the 3D messages
the node publishes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..frames import transform_from_position_quaternion
from ..limits import MAX_ABS_POSITION_M
from ..session import Detection

#: vision_msgs definitions as in ROS 1 noetic (``.msg`` text per type).
VISION_MSGS_ROS1: dict[str, str] = {
    "vision_msgs/msg/Detection2DArray": "std_msgs/Header header\nvision_msgs/Detection2D[] detections\n",
    "vision_msgs/msg/Detection2D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\n"
        "vision_msgs/BoundingBox2D bbox\nsensor_msgs/Image source_img\n"
    ),
    "vision_msgs/msg/ObjectHypothesisWithPose": "int64 id\nfloat64 score\ngeometry_msgs/PoseWithCovariance pose\n",
    "vision_msgs/msg/BoundingBox2D": "geometry_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n",
}
#: vision_msgs 4.x definitions, as in ROS 2 Humble and Jazzy (the 2D messages read and the 3D ones published).
VISION_MSGS_ROS2: dict[str, str] = {
    "vision_msgs/msg/Detection2DArray": "std_msgs/Header header\nvision_msgs/Detection2D[] detections\n",
    "vision_msgs/msg/Detection2D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\nvision_msgs/BoundingBox2D bbox\nstring id\n"
    ),
    "vision_msgs/msg/ObjectHypothesisWithPose": "vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n",
    "vision_msgs/msg/ObjectHypothesis": "string class_id\nfloat64 score\n",
    "vision_msgs/msg/BoundingBox2D": "vision_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n",
    "vision_msgs/msg/Pose2D": "vision_msgs/Point2D position\nfloat64 theta\n",
    "vision_msgs/msg/Point2D": "float64 x\nfloat64 y\n",
    "vision_msgs/msg/Detection3DArray": "std_msgs/Header header\nvision_msgs/Detection3D[] detections\n",
    "vision_msgs/msg/Detection3D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\nvision_msgs/BoundingBox3D bbox\nstring id\n"
    ),
    "vision_msgs/msg/BoundingBox3D": "geometry_msgs/Pose center\ngeometry_msgs/Vector3 size\n",
}
#: tf2_msgs/TFMessage, which the rosbags ROS 1 type store does not ship.
TF2_MSGS: dict[str, str] = {"tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n"}

#: Nanoseconds per second.
NS_PER_S = 1_000_000_000


def stamp_ns(stamp: Any) -> int:
    """A ``builtin_interfaces/Time`` (ROS 2 ``sec, nanosec``) or ROS 1 ``time`` (``sec, nsec``) in nanoseconds.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> stamp_ns(SimpleNamespace(sec=2, nanosec=5))
    2000000005
    """
    sec = int(getattr(stamp, "sec", 0))
    nsec = int(getattr(stamp, "nanosec", getattr(stamp, "nsec", 0)))
    return sec * NS_PER_S + nsec


def transform_from_msg(transform_stamped: Any, where: str) -> NDArray[np.float64]:
    """``T_parent_child``, shape (4, 4), of a ``geometry_msgs/TransformStamped`` (``header.frame_id`` the parent).

    Raises
    ------
    InputError
        ``WHERE: ...`` for a non-finite value, a translation beyond the position limit or a quaternion whose
        norm is not 1 (within 1e-3; it is normalised otherwise).
    """
    t, r = transform_stamped.transform.translation, transform_stamped.transform.rotation
    p = np.array([t.x, t.y, t.z], dtype=float)
    q = np.array([r.x, r.y, r.z, r.w], dtype=float)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise InputError(f"{where}: contains NaN or infinity")
    if not np.all(np.abs(p) <= MAX_ABS_POSITION_M):
        raise InputError(f"{where}: translation {np.max(np.abs(p)):.3g} m, beyond {MAX_ABS_POSITION_M:g} m")
    with np.errstate(over="ignore"):
        norm = float(np.linalg.norm(q))
    if not abs(norm - 1.0) <= 1e-3:
        raise InputError(f"{where}: rotation quaternion norm {norm:.4g}, expected 1")
    return transform_from_position_quaternion(p, q / norm)


def transforms_from_tf_message(msg: Any, where: str) -> Iterator[tuple[str, str, NDArray[np.float64], int]]:
    """The transforms of a ``tf2_msgs/TFMessage``: ``(parent, child, T_parent_child, stamp_ns)`` each.

    Raises
    ------
    InputError
        ``WHERE, transform K: ...`` for a transform :func:`transform_from_msg` refuses.
    """
    for k, tr in enumerate(msg.transforms):
        T = transform_from_msg(tr, f"{where}, transform {k}")
        yield str(tr.header.frame_id), str(tr.child_frame_id), T, stamp_ns(tr.header.stamp)


def detection_from_msg(d: Any, names: dict[int, str] | None = None) -> tuple[Detection | None, str | None]:
    """A :class:`~monovisual3d.session.Detection` from a ``vision_msgs/Detection2D`` (ROS 1 or ROS 2 layout).

    The box is the axis-aligned box around the (possibly rotated) ``bbox``, in pixels; the score and label
    are those of the best-scored hypothesis (a numeric class id becomes its name in ``names``).

    Returns
    -------
    detection : Detection or None
    reason : str or None, why there is no detection (a box that is not finite or has no area, a score
        outside [0, 1])
    """
    centre = d.bbox.center
    if hasattr(centre, "position"):
        cx, cy = float(centre.position.x), float(centre.position.y)
    else:
        cx, cy = float(centre.x), float(centre.y)
    theta = float(getattr(centre, "theta", 0.0))
    w, h = float(d.bbox.size_x), float(d.bbox.size_y)
    if not all(math.isfinite(v) for v in (cx, cy, w, h, theta)):
        return None, "box is not finite"
    if theta:
        c, s = abs(math.cos(theta)), abs(math.sin(theta))
        w, h = w * c + h * s, w * s + h * c
    if w <= 0 or h <= 0:
        return None, "box has no area"
    score, label = _best_hypothesis(d.results)
    if score is not None and not 0.0 <= score <= 1.0:
        return None, "score outside [0, 1]"
    if label is not None and names and label.isdigit() and int(label) in names:
        label = names[int(label)]
    box = np.array([cx - 0.5 * w, cy - 0.5 * h, cx + 0.5 * w, cy + 0.5 * h])
    return Detection(box, score=score, label=label), None


def _best_hypothesis(results: Any) -> tuple[float | None, str | None]:
    """Score and class id of the best-scored hypothesis (ROS 2 ``hypothesis.class_id``, ROS 1 ``id``)."""
    score = label = None
    best = -math.inf
    for r in results:
        hyp = getattr(r, "hypothesis", r)
        s = float(getattr(hyp, "score", math.nan))
        cid = getattr(hyp, "class_id", getattr(hyp, "id", None))
        if math.isfinite(s) and s > best:
            best, score = s, s
            label = None if cid is None or cid == "" else str(cid)
    return score, label


def detections_from_array(msg: Any, names: dict[int, str] | None = None) -> tuple[list[Detection], list[tuple[int, str]]]:
    """The detections of a ``vision_msgs/Detection2DArray``, and ``(index, reason)`` of each one left out."""
    kept: list[Detection] = []
    skipped: list[tuple[int, str]] = []
    for j, d in enumerate(msg.detections):
        det, reason = detection_from_msg(d, names)
        if det is None:
            skipped.append((j, reason or "unusable"))
        else:
            kept.append(det)
    return kept, skipped


__all__ = [
    "NS_PER_S",
    "TF2_MSGS",
    "VISION_MSGS_ROS1",
    "VISION_MSGS_ROS2",
    "detection_from_msg",
    "detections_from_array",
    "stamp_ns",
    "transform_from_msg",
    "transforms_from_tf_message",
]
