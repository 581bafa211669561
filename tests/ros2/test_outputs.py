"""Results -> messages: Detection3DArray fields, covariance layout, markers, status JSON, poses."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from monovisual3d.result import DetectedObject  # noqa: E402
from monovisual3d.ros2 import msgs  # noqa: E402
from monovisual3d.ros2.outputs import (  # noqa: E402
    CHI2_95_3D,
    UNKNOWN_VARIANCE,
    detection3d_array,
    marker_array,
    object_labels,
    pose_stamped,
    status_message,
    uncertainty_ellipsoid,
)
from monovisual3d.session import Detection, View  # noqa: E402

STAMP_NS = 1_800_000_000_123_456_789


def _objects(rng: np.random.Generator) -> list[DetectedObject]:
    A = rng.normal(size=(3, 3)) * 1e-3
    q = Rotation.random(random_state=rng).as_quat()
    sphere = DetectedObject(
        np.array([0.6, 0.0, 0.4]), 30.0, radius=0.03, covariance=A @ A.T, shape="sphere", associations={0: 0, 1: 0}
    )
    spheroid = DetectedObject.from_ellipsoid([0.7, 0.1, 0.5], [0.02, 0.02, 0.05], q, 12.0, "spheroid", associations={0: 1})
    return [sphere, spheroid]


def test_detection3d_fields(rng: np.random.Generator) -> None:
    objects = _objects(rng)
    msg = detection3d_array(objects, [7, 9], [("tomato", 0.8), ("", 1.0)], "base_link", STAMP_NS)
    assert msg.header.frame_id == "base_link"
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_800_000_000, 123_456_789)
    d0, d1 = msg.detections
    assert (d0.id, d1.id) == ("7", "9")
    assert_allclose([d0.bbox.center.position.x, d0.bbox.center.position.y, d0.bbox.center.position.z], objects[0].position)
    assert_allclose([d0.bbox.size.x, d0.bbox.size.y, d0.bbox.size.z], [0.06] * 3)
    assert_allclose([d1.bbox.size.x, d1.bbox.size.y, d1.bbox.size.z], [0.04, 0.04, 0.10])
    o = d1.bbox.center.orientation
    assert_allclose([o.x, o.y, o.z, o.w], objects[1].quaternion_xyzw)
    r = d0.results[0]
    assert (r.hypothesis.class_id, r.hypothesis.score) == ("tomato", 0.8)
    C = np.array(r.pose.covariance).reshape(6, 6)  # row-major
    assert_allclose(C[:3, :3], objects[0].covariance)
    assert_allclose(C[3:, 3:], np.eye(3) * UNKNOWN_VARIANCE)
    assert not C[:3, 3:].any() and not C[3:, :3].any()
    assert_allclose([r.pose.pose.position.x, r.pose.pose.position.y, r.pose.pose.position.z], objects[0].position)
    assert not np.array(d1.results[0].pose.covariance).reshape(6, 6)[:3, :3].any()  # no covariance: zeros (unknown)
    assert msgs.Detection3DArray.deserialize(msg.serialize()) == msg


def test_labels_and_box_scores_come_from_the_associated_boxes(rng: np.random.Generator) -> None:
    box = np.array([0.0, 0.0, 10.0, 10.0])
    views = [
        View(np.eye(4), (Detection(box, 0.9, "tomato"), Detection(box, None, None))),
        View(np.eye(4), (Detection(box, 0.7, "tomato"),)),
    ]
    assert object_labels(_objects(rng), views) == [("tomato", pytest.approx(0.8)), ("", 1.0)]


def test_markers(rng: np.random.Generator) -> None:
    objects = _objects(rng)
    m = marker_array(objects, [7, 9], [("tomato", 0.8), ("", 1.0)], "base_link", STAMP_NS).markers
    assert m[0].action == msgs.MARKER_DELETEALL
    kinds = [(x.ns, x.id, x.type) for x in m[1:]]
    assert ("fruit", 7, msgs.MARKER_SPHERE) in kinds and ("fruit_uncertainty", 7, msgs.MARKER_SPHERE) in kinds
    assert ("fruit_uncertainty", 9, msgs.MARKER_SPHERE) not in kinds  # no covariance, no ellipsoid
    assert [x.text for x in m if x.ns == "fruit_label"] == ["#7 tomato", "#9"]
    assert all(x.header.frame_id == "base_link" for x in m)


def test_uncertainty_ellipsoid_is_the_95_percent_one(rng: np.random.Generator) -> None:
    R = Rotation.random(random_state=rng).as_matrix()
    sd = np.array([0.001, 0.002, 0.004])
    extents, q = uncertainty_ellipsoid(R @ np.diag(sd**2) @ R.T)
    R_e = Rotation.from_quat(q).as_matrix()
    for k in range(3):  # each extent pairs with an axis of the covariance
        axis = R_e[:, k]
        var = axis @ R @ np.diag(sd**2) @ R.T @ axis
        assert extents[k] == pytest.approx(2 * np.sqrt(CHI2_95_3D * var), rel=1e-9)


def test_status_json_has_no_nan() -> None:
    msg = status_message({"estimate_s": float("nan"), "views": 3, "tracks": [{"position": [1.0, float("inf"), 0.0]}]})
    assert json.loads(msg.data) == {"estimate_s": None, "views": 3, "tracks": [{"position": [1.0, None, 0.0]}]}


def test_pose_stamped_round_trip(rng: np.random.Generator) -> None:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = [0.1, 0.2, 0.3]
    p = pose_stamped(T, "base_link", STAMP_NS).pose
    q = [p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]
    assert_allclose(Rotation.from_quat(q).as_matrix(), T[:3, :3], atol=1e-12)
    assert_allclose([p.position.x, p.position.y, p.position.z], T[:3, 3])
