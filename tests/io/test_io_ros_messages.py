"""ROS message fields -> library objects (the conversions the bag importer and the ROS 2 node share)."""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.errors import InputError
from monovisual3d.frames import transform_from_position_quaternion
from monovisual3d.io.ros_messages import (
    detection_from_msg,
    detections_from_array,
    stamp_ns,
    transform_from_msg,
    transforms_from_tf_message,
)


def _tf(parent: str, child: str, p, q, sec=1, nanosec=500) -> NS:
    header = NS(frame_id=parent, stamp=NS(sec=sec, nanosec=nanosec))
    t = NS(translation=NS(x=p[0], y=p[1], z=p[2]), rotation=NS(x=q[0], y=q[1], z=q[2], w=q[3]))
    return NS(header=header, child_frame_id=child, transform=t)


def _det2d(cx, cy, w, h, theta=0.0, results=()) -> NS:
    """ROS 2 (vision_msgs 4.x) layout."""
    return NS(bbox=NS(center=NS(position=NS(x=cx, y=cy), theta=theta), size_x=w, size_y=h), results=list(results))


def _hyp(class_id, score) -> NS:
    return NS(hypothesis=NS(class_id=class_id, score=score))


def test_stamp_ns_reads_ros1_and_ros2_stamps():
    assert stamp_ns(NS(sec=3, nanosec=7)) == 3_000_000_007
    assert stamp_ns(NS(sec=3, nsec=7)) == 3_000_000_007


def test_transform_from_msg_round_trip(rng):
    p, q = rng.uniform(-1, 1, 3), Rotation.random(random_state=rng).as_quat()
    assert_allclose(transform_from_msg(_tf("a", "b", p, q), "here"), transform_from_position_quaternion(p, q), atol=1e-12)
    ((parent, child, T, ns),) = transforms_from_tf_message(NS(transforms=[_tf("a", "b", p, q)]), "tf")
    assert (parent, child, ns) == ("a", "b", 1_000_000_500)
    assert_allclose(T, transform_from_position_quaternion(p, q), atol=1e-12)


def test_transform_from_msg_rejects_bad_values():
    with pytest.raises(InputError, match=r"^tf, transform 0: rotation quaternion norm 2, expected 1$"):
        list(transforms_from_tf_message(NS(transforms=[_tf("a", "b", [0, 0, 0], [0, 0, 0, 2])]), "tf"))
    with pytest.raises(InputError, match="here: contains NaN or infinity"):
        transform_from_msg(_tf("a", "b", [math.nan, 0, 0], [0, 0, 0, 1]), "here")
    with pytest.raises(InputError, match="here: translation 1e\\+07 m, beyond"):
        transform_from_msg(_tf("a", "b", [1e7, 0, 0], [0, 0, 0, 1]), "here")


def test_detection_from_msg_both_layouts():
    det, why = detection_from_msg(_det2d(100, 50, 20, 10, results=[_hyp("leaf", 0.2), _hyp("tomato", 0.9)]))
    assert why is None and det.label == "tomato" and det.score == 0.9
    assert_allclose(det.bbox_xyxy, [90, 45, 110, 55])
    ros1 = NS(bbox=NS(center=NS(x=100.0, y=50.0, theta=0.0), size_x=20.0, size_y=10.0), results=[NS(id=3, score=0.5)])
    det1, _ = detection_from_msg(ros1, names={3: "pepper"})
    assert det1.label == "pepper" and det1.score == 0.5
    assert_allclose(det1.bbox_xyxy, det.bbox_xyxy)


def test_a_rotated_box_becomes_the_box_around_it():
    det, _ = detection_from_msg(_det2d(0, 0, 20, 10, theta=np.pi / 2))
    assert_allclose(det.bbox_xyxy, [-5, -10, 5, 10], atol=1e-9)
    assert det.score is None and det.label is None


def test_detections_from_array_lists_what_it_leaves_out():
    msg = NS(
        detections=[
            _det2d(10, 10, 4, 4),
            _det2d(10, 10, 0, 4),
            _det2d(math.inf, 1, 1, 1),
            _det2d(5, 5, 2, 2, results=[_hyp("", 1.5)]),
        ]
    )
    kept, skipped = detections_from_array(msg)
    assert len(kept) == 1
    assert skipped == [(1, "box has no area"), (2, "box is not finite"), (3, "score outside [0, 1]")]
