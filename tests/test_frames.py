"""Rigid transforms, quaternions and the camera_link -> optical convention."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d import Camera, InputError
from monovisual3d.checks import check_quaternion_xyzw
from monovisual3d.frames import (
    QUATERNION_XYZW_CAMERALINK_OPTICAL,
    T_base_optical_from_T_base_cameralink,
    T_cameralink_optical,
    check_transform,
    invert_transform,
    look_at,
    position_quaternion_from_transform,
    quaternion_from_rotation,
    rotation_from_quaternion,
    transform_from_position_quaternion,
    transform_points,
)


def random_transforms(rng: np.random.Generator, n: int = 20) -> list[np.ndarray]:
    quats = Rotation.random(n, random_state=rng).as_quat()
    return [transform_from_position_quaternion(rng.uniform(-2, 2, 3), q) for q in quats]


def test_transform_times_inverse_is_identity(rng: np.random.Generator) -> None:
    for T in random_transforms(rng):
        assert_allclose(T @ invert_transform(T), np.eye(4), atol=1e-12)
        assert_allclose(invert_transform(T) @ T, np.eye(4), atol=1e-12)
        assert_allclose(invert_transform(T), np.linalg.inv(T), atol=1e-12)


def test_transform_points_composes(rng: np.random.Generator) -> None:
    """T_a_c = T_a_b @ T_b_c: applying the product equals applying the factors in turn."""
    T_a_b, T_b_c = random_transforms(rng, 2)
    p_c = rng.normal(size=(10, 3))
    assert_allclose(transform_points(T_a_b @ T_b_c, p_c), transform_points(T_a_b, transform_points(T_b_c, p_c)), atol=1e-12)
    p_h = np.column_stack([p_c, np.ones(10)])
    assert_allclose(transform_points(T_b_c, p_c), (p_h @ T_b_c.T)[:, :3], atol=1e-12)


def test_position_quaternion_round_trip(rng: np.random.Generator) -> None:
    positions = rng.uniform(-2, 2, (20, 3))
    quats = Rotation.random(20, random_state=rng).as_quat()
    for p, q in zip(positions, quats):
        p2, q2 = position_quaternion_from_transform(transform_from_position_quaternion(p, q))
        assert q2[3] >= 0
        assert_allclose(p2, p, atol=1e-12)
        assert_allclose(q2, q if q[3] >= 0 else -q, atol=1e-12)


def test_quaternion_conversions_match_scipy(rng: np.random.Generator) -> None:
    """The numpy conversions (no scipy.spatial import on a session's path) equal scipy's, unnormalised input too."""
    quats = rng.normal(size=(200, 4)) * rng.uniform(0.1, 3.0, (200, 1))
    for q in quats:
        R = rotation_from_quaternion(q)
        assert_allclose(R, Rotation.from_quat(q).as_matrix(), atol=1e-14)
        q_scipy = Rotation.from_matrix(R).as_quat()
        q_ours = quaternion_from_rotation(R)
        assert_allclose(q_ours, q_scipy if np.dot(q_ours, q_scipy) > 0 else -q_scipy, atol=1e-14)
    for R in (np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])):
        assert_allclose(rotation_from_quaternion(quaternion_from_rotation(R)), R, atol=1e-14)


def test_quaternion_order_is_xyzw() -> None:
    """(x, y, z, w) = (0, 0, sin 45, cos 45) turns base x into base y."""
    s = np.sqrt(0.5)
    T = transform_from_position_quaternion([0, 0, 0], [0, 0, s, s])
    assert_allclose(transform_points(T, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)


def test_check_quaternion_normalises_and_rejects() -> None:
    assert_allclose(check_quaternion_xyzw([0, 0, 0, 1.0005]), [0, 0, 0, 1])
    with pytest.raises(InputError, match=r"pose\.q: norm 2, expected 1 \(order is x, y, z, w\)"):
        check_quaternion_xyzw([0, 0, 0, 2], where="pose.q")
    with pytest.raises(InputError, match=r"q: expected shape \[4\], got \[3\]"):
        check_quaternion_xyzw([0, 0, 1], where="q")
    with pytest.raises(InputError, match=r"q: contains NaN or infinity"):
        check_quaternion_xyzw([0, 0, np.nan, 1], where="q")


def test_check_transform_accepts_rigid(rng: np.random.Generator) -> None:
    for T in random_transforms(rng, 5):
        assert_allclose(check_transform(T), T)


@pytest.mark.parametrize(
    ("matrix", "match"),
    [
        (np.diag([1.0, 1.0, 1.1, 1.0]), r"m: rotation block is not orthonormal"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), r"m: rotation block has determinant -1, expected \+1 \(a reflection"),
        (np.vstack([np.eye(4)[:3], [0.0, 0.0, 1.0, 1.0]]), r"m: last row is \[0\.0, 0\.0, 1\.0, 1\.0\], expected \[0, 0, 0, 1\]"),
        (np.eye(3), r"m: expected shape \[4, 4\], got \[3, 3\]"),
        (np.full((4, 4), np.inf), r"m: contains NaN or infinity"),
        ([["a"] * 4] * 4, r"m: expected numbers with shape \[4, 4\]"),
    ],
)
def test_check_transform_rejects(matrix: object, match: str) -> None:
    with pytest.raises(InputError, match=match):
        check_transform(matrix, where="m")  # type: ignore[arg-type]


def test_paper_quaternion_maps_camera_link_to_optical() -> None:
    """The paper's q = (-0.5, 0.5, -0.5, 0.5): optical z = link x, optical x = -link y, optical y = -link z."""
    assert_allclose(QUATERNION_XYZW_CAMERALINK_OPTICAL, [-0.5, 0.5, -0.5, 0.5])
    R = T_cameralink_optical()[:3, :3]
    assert_allclose(R @ [0, 0, 1], [1, 0, 0], atol=1e-12)  # forward
    assert_allclose(R @ [1, 0, 0], [0, -1, 0], atol=1e-12)  # right = -left
    assert_allclose(R @ [0, 1, 0], [0, 0, -1], atol=1e-12)  # down = -up


def test_point_ahead_of_camera_link_is_on_optical_axis(rng: np.random.Generator) -> None:
    for T_base_link in random_transforms(rng, 10):
        T_base_optical = T_base_optical_from_T_base_cameralink(T_base_link)
        ahead_base = transform_points(T_base_link, [2.0, 0.0, 0.0])  # 2 m along camera_link x
        left_up_base = transform_points(T_base_link, [1.0, 0.3, 0.2])  # left and up of the axis
        T_optical_base = invert_transform(T_base_optical)
        assert_allclose(transform_points(T_optical_base, ahead_base), [0.0, 0.0, 2.0], atol=1e-12)
        assert_allclose(transform_points(T_optical_base, left_up_base), [-0.3, -0.2, 1.0], atol=1e-12)
        # same camera centre
        assert_allclose(T_base_optical[:3, 3], T_base_link[:3, 3])


def test_look_at(rng: np.random.Generator) -> None:
    cam = Camera.from_hfov(640, 480, 69.0)
    up = np.array([0.0, 0.0, 1.0])
    for _ in range(20):
        position, target = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3) + [2, 0, 0]
        T = check_transform(look_at(position, target))  # a proper rigid transform
        assert_allclose(T[:3, 3], position)
        forward = (target - position) / np.linalg.norm(target - position)
        assert_allclose(T[:3, 2], forward, atol=1e-12)
        assert T[:3, 1] @ up < 0  # image y (down) points against base up
        assert abs(T[:3, 0] @ up) < 1e-12  # image x stays horizontal
        target_optical = transform_points(invert_transform(T), target)
        assert_allclose(cam.project(target_optical), [cam.cx, cam.cy], atol=1e-9)


def test_look_at_along_base_x_matches_camera_link_convention() -> None:
    """A camera looking along base x with z up is the camera_link identity pose."""
    assert_allclose(look_at([0, 0, 0], [1, 0, 0]), T_base_optical_from_T_base_cameralink(np.eye(4)), atol=1e-12)


def test_look_at_straight_down_and_degenerate() -> None:
    T = look_at([0, 0, 1], [0, 0, 0])  # forward parallel to up: falls back to another up
    assert_allclose(T[:3, 2], [0, 0, -1], atol=1e-12)
    check_transform(T)
    with pytest.raises(InputError, match="look_at: position and target coincide"):
        look_at([1, 2, 3], [1, 2, 3])
