"""Pose readers, hand-eye calibrations, eye-in-hand composition and interpolation."""

from __future__ import annotations

import numpy as np
import pytest
from io_scene import geodesic
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.errors import InputError
from monovisual3d.frames import invert_transform, transform_from_position_quaternion
from monovisual3d.io import (
    T_base_camera_from_T_base_ee,
    T_base_ee_from_T_base_camera,
    interpolate_poses,
    read_hand_eye,
    read_pose_csv,
    read_pose_json,
    read_poses,
    read_tum,
)


def random_poses(rng: np.random.Generator, n: int) -> np.ndarray:
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.uniform(-1, 1, (n, 3))
    return T


def test_tum_fixture(fixtures):
    traj = read_poses(fixtures / "poses_tum.txt")
    assert len(traj) == 4 and traj.images is None
    assert_allclose(traj.stamps - 1_700_000_000, [0.0, 0.1, 0.2, 1.0], atol=1e-6)
    assert_allclose(traj.T_base_frame[0], transform_from_position_quaternion([0.18, 0, 0.47], [-0.5, 0.5, -0.5, 0.5]))


def test_tum_is_sorted_and_rejects_duplicates_and_bad_rows(tmp_path):
    p = tmp_path / "t.txt"
    p.write_text("2 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n")
    traj = read_tum(p)
    assert_allclose(traj.stamps, [1, 2])
    assert_allclose(traj.T_base_frame[:, 0, 3], [1, 0])
    p.write_text("1 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n")
    with pytest.raises(InputError, match=r"t.txt: two poses share the stamp 1.0 s"):
        read_tum(p)
    p.write_text("1 0 0 0 0 0 0.5 0.5\n")
    with pytest.raises(InputError, match=r"t.txt: line 1: quaternion \(qx qy qz qw\): norm 0.7071, expected 1"):
        read_tum(p)
    p.write_text("1 0 0 0 0 0 1\n")
    with pytest.raises(InputError, match="t.txt: line 1: 7 values, expected 8: timestamp tx ty tz qx qy qz qw"):
        read_tum(p)


def test_csv_with_images_fixture(fixtures):
    traj = read_poses(fixtures / "poses.csv")
    assert traj.images == ("img_000.png", "img_001.png", "img_002.png")
    q = [-0.448879201, 0.548630135, -0.498754668, 0.498754668]
    assert_allclose(traj.T_base_frame[1], transform_from_position_quaternion([0.2, 0.1, 0.48], q), atol=1e-9)


def test_csv_rotation_vector_in_millimetres(fixtures):
    traj = read_poses(fixtures / "poses_ur.csv", units="mm")
    assert_allclose(traj.T_base_frame[1, :3, 3], [0.2, 0.1, 0.48])
    assert_allclose(traj.T_base_frame[1, :3, :3], Rotation.from_rotvec([0.1, 3.0, 0.0]).as_matrix())


def test_csv_roll_pitch_yaw(tmp_path):
    (tmp_path / "p.csv").write_text("stamp_ns,x,y,z,roll,pitch,yaw\n1500000000,1,2,3,0.1,0.2,0.3\n")
    traj = read_pose_csv(tmp_path / "p.csv")
    assert_allclose(traj.stamps, [1.5])
    Rz, Ry, Rx = (Rotation.from_rotvec(a * np.eye(3)[i]).as_matrix() for i, a in ((2, 0.3), (1, 0.2), (0, 0.1)))
    assert_allclose(traj.T_base_frame[0, :3, :3], Rz @ Ry @ Rx, atol=1e-12)  # ROS RPY convention
    (tmp_path / "q.csv").write_text("x,y,z,w\n1,2,3,4\n")
    with pytest.raises(InputError, match="needs an orientation: qx, qy, qz, qw or rx, ry, rz or roll, pitch, yaw"):
        read_pose_csv(tmp_path / "q.csv")


def test_json_poses(fixtures, rng):
    traj = read_poses(fixtures / "poses.json")
    assert traj.T_base_frame.shape == (2, 4, 4) and traj.stamps is None
    T = random_poses(rng, 3)
    items = [{"matrix": T[0].tolist(), "stamp": 3.0, "image": "c.png"}]
    for i, t in ((1, 1.0), (2, 2.0)):
        p = T[i, :3, 3].tolist()
        q = Rotation.from_matrix(T[i, :3, :3]).as_quat().tolist()
        items.append({"position": p, "quaternion_xyzw": q, "stamp": t, "image": f"{'ab'[i - 1]}.png"})
    traj = read_pose_json({"poses": items})
    assert traj.images == ("a.png", "b.png", "c.png")
    assert_allclose(traj.T_base_frame, T[[1, 2, 0]], atol=1e-12)
    bad = np.eye(4)
    bad[0, 0] = -1
    with pytest.raises(InputError, match=r"poses: poses\[0\]: rotation block has determinant -1, expected \+1"):
        read_pose_json([bad.tolist()])
    with pytest.raises(InputError, match=r"pose 1 has no stamp while others do"):
        read_pose_json([{"matrix": np.eye(4).tolist(), "stamp": 1}, {"matrix": np.eye(4).tolist()}])


def test_hand_eye_formats_agree(fixtures):
    a = read_hand_eye(fixtures / "hand_eye_easy_handeye.yaml")
    b = read_hand_eye(fixtures / "hand_eye_opencv.json")
    assert_allclose(a, b, atol=1e-12)
    c = read_hand_eye({"position": [32, -45, 61], "quaternion_xyzw": [0, 0, 0.7071067811865476, 0.7071067811865476]}, units="mm")
    assert_allclose(a, c, atol=1e-12)
    assert_allclose(read_hand_eye(a.tolist()), a)
    with pytest.raises(InputError, match=r"hand_eye: transformation.qw: missing field"):
        read_hand_eye({"transformation": {"x": 0, "y": 0, "z": 0, "qx": 0, "qy": 0, "qz": 0}})


def test_eye_in_hand_composition(rng):
    T_base_ee = random_poses(rng, 5)
    T_ee_camera = random_poses(rng, 1)[0]
    T_base_camera = T_base_camera_from_T_base_ee(T_base_ee, T_ee_camera)
    assert T_base_camera.shape == (5, 4, 4)
    # the camera centre is the hand-eye offset carried by the end effector
    assert_allclose(T_base_camera[:, :3, 3], T_base_ee[:, :3, 3] + T_base_ee[:, :3, :3] @ T_ee_camera[:3, 3])
    assert_allclose(T_base_camera_from_T_base_ee(T_base_camera, invert_transform(T_ee_camera)), T_base_ee, atol=1e-12)
    # and back: the end-effector pose that puts the camera there
    assert_allclose(T_base_ee_from_T_base_camera(T_base_camera, T_ee_camera), T_base_ee, atol=1e-12)


def test_interpolation_at_samples_and_between(rng):
    T = random_poses(rng, 4)
    st = np.array([0.0, 0.1, 0.25, 0.3])
    Tq, ok, why = interpolate_poses(st, T, st, max_gap=0.2)
    assert ok.all() and why == [None] * 4
    assert_allclose(Tq, T, atol=1e-12)
    q = np.array([0.03, 0.2, 0.29])
    Tq, ok, _ = interpolate_poses(st, T, q, max_gap=0.2)
    for i, t in enumerate(q):
        j = np.searchsorted(st, t) - 1
        s = (t - st[j]) / (st[j + 1] - st[j])
        assert_allclose(Tq[i], geodesic(T[j], T[j + 1], s), atol=1e-9)


def test_interpolation_gap_rules(rng):
    T = random_poses(rng, 3)
    st = np.array([0.0, 1.0, 1.05])
    Tq, ok, why = interpolate_poses(st, T, [0.04, 0.5, 1.1, -0.5, 1.2], max_gap=0.1)
    assert ok.tolist() == [True, False, True, False, False]
    assert_allclose(Tq[0], T[0])  # only the sample before is close: held
    assert_allclose(Tq[2], T[2])  # past the end by less than max_gap: held
    assert why[1] == "poses 0.5 s before and 0.5 s after, both more than max_gap 0.1 s"
    assert why[3] == "0.5 s before the first pose, more than max_gap 0.1 s"
    assert why[4] == "0.15 s after the last pose, more than max_gap 0.1 s"
    with pytest.raises(InputError, match=r"--max-gap \(max_gap\): got -1.0, expected seconds >= 0"):
        interpolate_poses(st, T, [0.0], max_gap=-1)
    with pytest.raises(InputError, match="stamps must be strictly increasing"):
        interpolate_poses([0.0, 0.0, 1.0], T, [0.0], max_gap=1)
