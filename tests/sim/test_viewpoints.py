"""Viewpoints: the paper's three poses, permutations, rings, hemispheres, user poses."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.camera import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, transform_points
from monovisual3d.sim.viewpoints import (
    DEFAULT_TARGET,
    arc_poses,
    check_poses,
    hemisphere_poses,
    load_poses,
    paper_poses,
    pose_permutations,
    poses_by_name,
    poses_from_positions,
    ring_poses,
    row_poses,
)

TARGET = np.array(DEFAULT_TARGET)
CAM = Camera.from_hfov(640, 480, 69.0)


def assert_looks_at(poses, target):
    for T in poses:
        assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)
        assert_allclose(np.linalg.det(T[:3, :3]), 1.0, atol=1e-12)
        uv = CAM.project(transform_points(invert_transform(T), target))
        assert_allclose(uv, [320.0, 240.0], atol=1e-9)  # the target is on the optical axis
        assert T[2, 1] <= 1e-12  # image "down" never points up in the base frame (look_at with z up)


def test_paper_poses_geometry():
    P = paper_poses()
    assert P.shape == (3, 4, 4)
    assert_looks_at(P, TARGET)
    assert_allclose(P[:, :3, 3], TARGET + np.array([[-0.5, 0.0, 0.0], [-0.5, 0.2, -0.2], [-0.5, -0.2, 0.2]]), atol=1e-12)
    z = P[:, :3, 2]  # optical axes in the base frame
    assert_allclose(z[0], [1.0, 0.0, 0.0], atol=1e-12)  # pose 1 looks straight ahead
    assert z[1, 2] > 0.2 and z[2, 2] < -0.2  # pose 2 looks up, pose 3 looks down
    # pose 2 moved to the image's left of pose 1 (negative optical x of pose 1), pose 3 to its right
    x1 = P[0, :3, 0]
    assert (P[1, :3, 3] - P[0, :3, 3]) @ x1 < 0 < (P[2, :3, 3] - P[0, :3, 3]) @ x1


def test_paper_poses_custom_target_distance_and_direction():
    target = np.array([1.0, 2.0, 0.3])
    P = paper_poses(target, distance=0.8, offset=0.1, view_direction=(0.0, 1.0, 0.0))
    assert_looks_at(P, target)
    assert_allclose(np.linalg.norm(P[0, :3, 3] - target), 0.8)
    assert_allclose(P[0, :3, 2], [0.0, 1.0, 0.0], atol=1e-12)
    assert_allclose(np.linalg.norm(P[1, :3, 3] - P[0, :3, 3]), 0.1 * math.sqrt(2))


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_pose_permutations_count_and_content(n):
    P = ring_poses(n=n)
    perms = pose_permutations(P)
    assert len(perms) == math.factorial(n)
    orders = [order for order, _ in perms]
    assert len(set(orders)) == len(orders)
    assert orders[0] == tuple(range(n))
    for order, poses in perms:
        assert sorted(order) == list(range(n))
        assert_array_equal(poses, P[list(order)])


def test_ring_poses():
    P = ring_poses(TARGET, 6, distance=0.4, cone_angle=math.radians(25))
    assert P.shape == (6, 4, 4)
    assert_looks_at(P, TARGET)
    offsets = P[:, :3, 3] - TARGET
    assert_allclose(np.linalg.norm(offsets, axis=1), 0.4)
    angles = np.degrees(np.arccos(-offsets[:, 0] / 0.4))  # angle from the axis (camera side is -x)
    assert_allclose(angles, 25.0)
    assert_allclose(offsets.mean(axis=0)[1:], 0.0, atol=1e-12)  # evenly spread around the axis
    # the first one is to the image's right of the axial view (base -y)
    assert offsets[0, 1] < 0 and abs(offsets[0, 2]) < 1e-12


def test_hemisphere_poses():
    P = hemisphere_poses(TARGET, 20, distance=0.5, max_angle=math.radians(80))
    assert P.shape == (20, 4, 4)
    assert_looks_at(P, TARGET)
    offsets = P[:, :3, 3] - TARGET
    assert_allclose(np.linalg.norm(offsets, axis=1), 0.5)
    angles = np.degrees(np.arccos(np.clip(-offsets[:, 0] / 0.5, -1, 1)))
    assert angles[0] == pytest.approx(0.0, abs=1e-6)
    assert angles.max() == pytest.approx(80.0)
    assert np.all(np.diff(angles) > 0)
    full = hemisphere_poses(TARGET, 9, max_angle=math.pi / 2)  # includes views from straight above/below
    assert_looks_at(full, TARGET)


def test_poses_from_positions_and_check_poses():
    P = poses_from_positions([[0.0, 0.0, 0.45], [0.2, 0.3, 0.8]], TARGET)
    assert_looks_at(P, TARGET)
    assert check_poses(P).shape == (2, 4, 4)
    with pytest.raises(InputError, match=r"poses\[1\]"):
        check_poses(np.stack([np.eye(4), 2 * np.eye(4)]))
    with pytest.raises(InputError, match=r"poses: expected shape \(N, 4, 4\)"):
        check_poses(np.zeros((3, 3)))
    with pytest.raises(InputError, match="positions"):
        poses_from_positions([[0.0, 0.0]], TARGET)


def test_poses_by_name():
    assert_array_equal(poses_by_name("paper"), paper_poses())
    assert_array_equal(poses_by_name("ring:5"), ring_poses(TARGET, 5))
    assert_array_equal(poses_by_name("ring:4:30"), ring_poses(TARGET, 4, cone_angle=math.radians(30)))
    assert_array_equal(poses_by_name("hemisphere:7:45"), hemisphere_poses(TARGET, 7, max_angle=math.radians(45)))
    for bad, message in [
        ("rings:3", "views: got 'rings:3'"),
        ("ring:x", "ring:N or ring:N:ANGLE_DEG"),
        ("ring:0", "--views: got 'ring:0', expected ring:N with N >= 1 views"),
        ("ring:3:100", r"--views: got 'ring:3:100', expected the cone half-angle ANGLE_DEG in \[0, 90\] degrees"),
        ("hemisphere", "views: got 'hemisphere'"),
    ]:
        with pytest.raises(InputError, match=message):
            poses_by_name(bad)


def test_load_poses(tmp_path):
    T = paper_poses()[1]
    from monovisual3d.frames import position_quaternion_from_transform

    p, q = position_quaternion_from_transform(T)
    data = {
        "poses": [
            {"position": p.tolist(), "quaternion_xyzw": q.tolist()},
            {"matrix": T.tolist()},
            {"position": [0.1, 0.0, 0.45]},
            {"position": [0.1, 0.1, 0.45], "target": [0.6, 0.1, 0.45]},
        ]
    }
    path = tmp_path / "poses.json"
    path.write_text(json.dumps(data))
    P = load_poses(path)
    assert P.shape == (4, 4, 4)
    assert_allclose(P[0], T, atol=1e-9)
    assert_allclose(P[1], T, atol=1e-12)
    assert_allclose(P[2], paper_poses()[0], atol=1e-12)
    assert_allclose(P[3, :3, 2], [1.0, 0.0, 0.0], atol=1e-12)
    assert_allclose(poses_by_name(str(path)), P)
    path.write_text(json.dumps([{"position": [0, 0, 0], "colour": "red"}]))
    with pytest.raises(InputError, match=r"poses\[0\]\.colour: unknown field"):
        load_poses(path)
    path.write_text(json.dumps([{"position": [0, 0, 0], "quaternion_xyzw": [0, 0, 0, 2]}]))
    with pytest.raises(InputError, match=r"poses\[0\]\.quaternion_xyzw: norm 2"):
        load_poses(path)


def test_bad_geometry_is_rejected():
    with pytest.raises(InputError, match="distance: got -0.5"):
        paper_poses(distance=-0.5)
    with pytest.raises(InputError, match="view_direction: zero vector"):
        paper_poses(view_direction=(0, 0, 0))
    with pytest.raises(InputError, match="target"):
        ring_poses([0.0, 1.0], 3)


def test_arc_poses_sweep_left_to_right_at_the_targets_height():
    P = arc_poses(TARGET, 5, span=math.radians(60.0), distance=0.5)
    assert_looks_at(P, TARGET)
    assert_allclose(np.linalg.norm(P[:, :3, 3] - TARGET, axis=1), 0.5)
    assert_allclose(P[:, 2, 3], TARGET[2], atol=1e-12)  # a horizontal arc
    d = P[:, :3, 3] - TARGET
    azimuth = np.degrees(np.arctan2(d[:, 1], -d[:, 0]))  # 0 = the axial view, base +y = the image's left
    assert_allclose(azimuth, [30.0, 15.0, 0.0, -15.0, -30.0], atol=1e-9)
    assert_allclose(arc_poses(TARGET, 1)[0], arc_poses(TARGET, 3, span=0.0)[1], atol=1e-12)


def test_paths_give_the_camera_between_and_beyond_their_views():
    """``at``: continuous view positions along the constant-speed path (integers: the views themselves)."""
    arc = arc_poses(TARGET, 4, span=math.radians(45.0))
    assert_allclose(arc_poses(TARGET, 4, span=math.radians(45.0), at=[0, 1, 2, 3]), arc, atol=1e-12)
    beyond = arc_poses(TARGET, 4, span=math.radians(45.0), at=[4.0])[0]
    step = np.linalg.inv(arc[2]) @ arc[3]  # the same motion from view to view
    assert_allclose(beyond, arc[3] @ step, atol=1e-12)
    row = row_poses(3, TARGET, length=0.4)
    assert_allclose(row_poses(3, TARGET, length=0.4, at=[0.5, -1.0])[:, 1, 3], [0.1, 0.4], atol=1e-12)
    assert_allclose(row_poses(3, TARGET, length=0.4, at=[2])[0], row[2], atol=1e-12)
    with pytest.raises(InputError, match="at: .*finite view positions"):
        arc_poses(TARGET, 4, at=[np.nan])


def test_poses_by_name_arc_and_paths_only_for_at():
    assert_allclose(poses_by_name("arc:5:40"), arc_poses(TARGET, 5, span=math.radians(40.0)), atol=1e-12)
    assert_allclose(poses_by_name("arc:6"), arc_poses(TARGET, 6), atol=1e-12)  # 60 degrees
    assert poses_by_name("row:4", at=[0.5, 1.5]).shape == (2, 4, 4)
    with pytest.raises(InputError, match="views along a path"):
        poses_by_name("ring:4", at=[0.5])
    with pytest.raises(InputError, match=r"angle swept ANGLE_DEG in \[0, 360\]"):
        poses_by_name("arc:4:400")
    with pytest.raises(InputError, match="arc:N or arc:N:ANGLE_DEG with N an integer"):
        poses_by_name("arc:x")
