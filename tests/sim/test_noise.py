"""The simulator's noise model: statistics on large samples, seeds, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.spatial.transform import Rotation

from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.sim.noise import (
    NoiseModel,
    clip_boxes_to_image,
    drop_mask,
    false_positive_boxes,
    perturb_boxes,
    perturb_pose,
    visible_part_boxes,
    wholly_hidden,
)

N = 40_000
BOX = np.array([200.0, 150.0, 280.0, 190.0])  # centre (240, 170), width 80, height 40


def test_box_noise_statistics_match_the_documented_model():
    sigma = 0.05
    out = perturb_boxes(np.tile(BOX, (N, 1)), sigma, rng=0)
    w, h = out[:, 2] - out[:, 0], out[:, 3] - out[:, 1]
    du = (0.5 * (out[:, 0] + out[:, 2]) - 240.0) / 80.0  # centre shift in box widths
    dv = (0.5 * (out[:, 1] + out[:, 3]) - 170.0) / 40.0
    for rel in (du, dv, w / 80.0 - 1.0, h / 40.0 - 1.0):
        assert abs(rel.mean()) < 4 * sigma / math.sqrt(N)  # mean 0 (4 standard errors)
        assert_allclose(rel.std(), sigma, rtol=0.03)  # std 0.05 (the standard error of a std is 0.35 % here)
    # the four perturbations are independent
    corr = np.corrcoef(np.stack([du, dv, w, h]))
    assert np.max(np.abs(corr - np.eye(4))) < 0.03


def test_zero_box_noise_changes_nothing():
    assert_array_equal(perturb_boxes(BOX[None], 0.0, rng=1), BOX[None])


def test_drop_probability():
    dropped = drop_mask(N, 0.02, rng=0)
    assert dropped.shape == (N,) and dropped.dtype == bool
    assert abs(dropped.mean() - 0.02) < 5 * math.sqrt(0.02 * 0.98 / N)
    assert not drop_mask(100, 0.0, rng=0).any()
    assert drop_mask(100, 1.0, rng=0).all()


def test_false_positives_count_and_size():
    rng = np.random.default_rng(0)
    boxes = [false_positive_boxes((640, 480), 1.5, rng, size_range_px=(20.0, 60.0)) for _ in range(4000)]
    counts = np.array([len(b) for b in boxes])
    assert abs(counts.mean() - 1.5) < 5 * math.sqrt(1.5 / 4000)  # Poisson mean
    assert_allclose(counts.var(), 1.5, rtol=0.1)  # Poisson variance = mean
    allb = np.concatenate(boxes)
    w = allb[:, 2] - allb[:, 0]
    assert w.min() >= 20.0 and w.max() <= 60.0
    aspect = (allb[:, 3] - allb[:, 1]) / w
    assert aspect.min() >= 0.8 - 1e-9 and aspect.max() <= 1.25 + 1e-9
    centres = 0.5 * (allb[:, :2] + allb[:, 2:])
    assert_allclose(centres.mean(axis=0), [320.0, 240.0], atol=5.0)


def test_apply_to_boxes_drops_clips_and_tracks_sources():
    model = NoiseModel(box_sigma=0.05, drop_probability=0.5, false_positive_rate=2.0)
    boxes = np.array([[10.0, 10.0, 50.0, 40.0], [600.0, 400.0, 640.0, 480.0], [300.0, 200.0, 340.0, 240.0]])
    n_true = n_fp = 0
    for seed in range(300):
        out, source = model.apply_to_boxes(boxes, (640, 480), rng=seed)
        assert out.shape == (len(source), 4)
        assert np.all(out[:, [0, 2]] >= 0) and np.all(out[:, [0, 2]] <= 640)
        assert np.all(out[:, [1, 3]] >= 0) and np.all(out[:, [1, 3]] <= 480)
        assert np.all(out[:, 2] - out[:, 0] >= 1.0) and np.all(out[:, 3] - out[:, 1] >= 1.0)
        true_part = source >= 0
        assert np.all(np.diff(source[true_part]) > 0)  # true detections keep their order, first
        assert np.all(true_part[: true_part.sum()])
        for k, b in zip(source[true_part], out[true_part]):  # a noisy box stays near its source
            assert np.all(np.abs(b - boxes[k]) < 0.5 * (boxes[k, 2] - boxes[k, 0]) + 1)
        n_true += int(true_part.sum())
        n_fp += int((~true_part).sum())
    assert abs(n_true / (3 * 300) - 0.5) < 0.06
    assert 1.5 < n_fp / 300 < 2.1  # some false positives fall outside the image or are clipped too thin


def test_noiseless_model_returns_the_boxes_unchanged():
    model = NoiseModel()
    assert model.is_noiseless
    out, source = model.apply_to_boxes(np.array([[1.0, 2.0, 30.0, 40.0]]), (640, 480), rng=0)
    assert_array_equal(out, [[1.0, 2.0, 30.0, 40.0]])
    assert_array_equal(source, [0])
    T = look_at([0.1, 0, 0.45], [0.6, 0, 0.45])
    assert_array_equal(model.apply_to_pose(T, rng=0), T)
    empty, src = model.apply_to_boxes(np.zeros((0, 4)), (640, 480), rng=0)
    assert empty.shape == (0, 4) and src.shape == (0,)


def test_pose_error_statistics():
    T = look_at([0.1, 0.0, 0.45], [0.6, 0.0, 0.45])
    rng = np.random.default_rng(0)
    n = 1500
    dp = np.empty((n, 3))
    rotvec = np.empty((n, 3))
    for i in range(n):
        Tp = perturb_pose(T, 0.002, math.radians(0.5), rng)
        dp[i] = Tp[:3, 3] - T[:3, 3]
        rotvec[i] = Rotation.from_matrix(T[:3, :3].T @ Tp[:3, :3]).as_rotvec()  # error in the optical frame
    # the standard error of a sample std is std / sqrt(2 n) = 1.8 % here
    assert_allclose(dp.std(axis=0), 0.002, rtol=0.08)
    assert_allclose(dp.mean(axis=0), 0.0, atol=4 * 0.002 / math.sqrt(n))
    assert_allclose(rotvec.std(axis=0), math.radians(0.5), rtol=0.08)
    assert_allclose(rotvec.mean(axis=0), 0.0, atol=4 * math.radians(0.5) / math.sqrt(n))
    assert_allclose(Tp[:3, :3].T @ Tp[:3, :3], np.eye(3), atol=1e-12)


def test_from_mm_deg_converts_units():
    m = NoiseModel.from_mm_deg(pose_error_mm=2.0, pose_error_deg=0.5)
    assert m.pose_position_std == pytest.approx(0.002)
    assert m.pose_rotation_std == pytest.approx(math.radians(0.5))
    assert NoiseModel.paper().box_sigma == 0.05 and NoiseModel.paper().drop_probability == 0.02
    assert NoiseModel.paper(drop_probability=0.0).drop_probability == 0.0


def test_same_seed_same_noise_and_different_seed_different_noise():
    model = NoiseModel(
        box_sigma=0.05, drop_probability=0.1, false_positive_rate=1.0, pose_position_std=0.01, pose_rotation_std=0.01
    )
    boxes = np.tile(BOX, (10, 1))
    a = model.apply_to_boxes(boxes, (640, 480), rng=7)
    b = model.apply_to_boxes(boxes, (640, 480), rng=7)
    c = model.apply_to_boxes(boxes, (640, 480), rng=8)
    assert_array_equal(a[0], b[0])
    assert_array_equal(a[1], b[1])
    assert a[0].shape != c[0].shape or not np.array_equal(a[0], c[0])
    T = np.eye(4)
    assert_array_equal(model.apply_to_pose(T, rng=3), model.apply_to_pose(T, rng=3))
    assert not np.array_equal(model.apply_to_pose(T, rng=3), model.apply_to_pose(T, rng=4))


def test_clip_boxes_to_image():
    b, ok = clip_boxes_to_image([[-10, -5, 20, 30], [700, 10, 800, 50], [5, 5, 5.5, 20]], 640, 480)
    assert_array_equal(b[0], [0, 0, 20, 30])
    assert_array_equal(ok, [True, False, False])


def test_visible_part_boxes_end_where_a_nearer_box_begins():
    near = [100.0, 50, 200, 300]
    boxes = np.array(
        [
            [near, [150.0, 60, 260, 290]],  # the farther one hidden on its left
            [near, [50.0, 60, 150, 290]],  # on its right
            [near, [120.0, 60, 180, 290]],  # wholly behind: its strips still span it
            [near, [150.0, 30, 260, 290]],  # its top shows above the nearer one: its box stays whole
        ]
    )
    out = visible_part_boxes(boxes, np.tile([0.5, 0.6], (4, 1)))
    assert_array_equal(out[:, 0], boxes[:, 0])  # the nearer box is never cut
    assert_array_equal(out[:, 1], [[200, 60, 260, 290], [50, 60, 100, 290], [120, 60, 180, 290], [150, 30, 260, 290]])
    swapped = visible_part_boxes(boxes, np.tile([0.6, 0.5], (4, 1)))  # now the first is the farther one
    assert_array_equal(swapped[0, 0], [100, 50, 200, 300])  # it is taller: its top and bottom show
    with pytest.raises(ValueError, match=r"expected shapes \(K, N, 4\) and \(K, N\)"):
        visible_part_boxes(boxes, np.zeros(4))


def test_wholly_hidden_objects_are_those_behind_a_nearer_box_or_down_to_a_sliver():
    near = [100.0, 50, 200, 300]
    boxes = np.array(
        [
            [near, [120.0, 60, 180, 290]],  # wholly behind
            [near, [150.0, 60, 260, 290]],  # its right part shows
            [near, [150.0, 30, 180, 290]],  # its top shows
            [near, [100.0, 60, 201.5, 290]],  # a 1.5 px sliver shows
        ]
    )
    assert_array_equal(wholly_hidden(boxes, np.tile([0.5, 0.6], (4, 1))), [[0, 1], [0, 0], [0, 0], [0, 1]])
    assert_array_equal(wholly_hidden(boxes, np.tile([0.5, 0.6], (4, 1)), min_visible_px=1.0)[3], [0, 0])
    assert not wholly_hidden(boxes, np.tile([0.6, 0.5], (4, 1)))[:, 0].any()  # the first, now farther, shows
    with pytest.raises(ValueError, match=r"expected shapes \(K, N, 4\) and \(K, N\)"):
        wholly_hidden(boxes, np.zeros(4))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"box_sigma": -0.1}, r"--noise \(noise.box_sigma\): got -0.1"),
        ({"box_sigma": float("nan")}, "noise.box_sigma"),
        ({"drop_probability": 1.5}, r"--drop \(noise.drop_probability\): got 1.5"),
        ({"false_positive_rate": -1}, r"--false-positives \(noise.false_positive_rate\)"),
        ({"false_positive_size_px": (50, 10)}, "noise.false_positive_size_px"),
        ({"pose_position_std": -0.001}, "noise.pose_position_std"),
        ({"hand_eye_rotation_std": -0.001}, "noise.hand_eye_rotation_std"),
        ({"hand_eye_position_std": 10.0}, "noise.hand_eye_position_std: got 10, more than"),
    ],
)
def test_bad_noise_parameters_are_rejected(kwargs, message):
    with pytest.raises(InputError, match=message):
        NoiseModel(**kwargs)


def test_bad_inputs_are_rejected():
    with pytest.raises(InputError, match=r"boxes_xyxy: expected shape \(N, 4\)"):
        perturb_boxes(np.zeros((2, 3)), 0.05, rng=0)
    with pytest.raises(InputError, match="x2 < x1"):
        perturb_boxes([[10, 10, 5, 20]], 0.05, rng=0)
    with pytest.raises(InputError, match="drop_probability"):
        drop_mask(3, -0.1)
    with pytest.raises(InputError, match="T_base_optical"):
        perturb_pose(np.ones((4, 4)), 0.0, 0.0)
    with pytest.raises(InputError, match="pose_error_mm"):
        NoiseModel.from_mm_deg(pose_error_mm=-1.0)
    with pytest.raises(InputError, match=r"--hand-eye-error-deg \(hand_eye_error_deg\): got -1"):
        NoiseModel.from_mm_deg(hand_eye_error_deg=-1.0)


def test_a_hand_eye_error_is_one_rigid_motion_in_the_camera_frame_shared_by_every_view():
    """Every view's reported pose is its true pose times the same ``E`` (no per-view error here); ``E`` has the
    stated spread over sessions; without one nothing is drawn, so sessions without it keep their numbers."""
    from monovisual3d.sim.scenes import paper_scene
    from monovisual3d.sim.simulate import simulate_views

    model = NoiseModel.from_mm_deg(hand_eye_error_mm=2.0, hand_eye_error_deg=0.5)
    assert model.hand_eye_position_std == pytest.approx(0.002) and not model.is_noiseless
    svs = simulate_views(paper_scene(), noise=model, rng=3)
    E = [np.linalg.inv(sv.T_base_optical_true) @ sv.T_base_optical_reported for sv in svs]
    assert_allclose(E[1], E[0], atol=1e-12)
    assert_allclose(E[2], E[0], atol=1e-12)
    assert np.linalg.norm(E[0][:3, 3]) > 1e-4
    plain = simulate_views(paper_scene(), noise=NoiseModel(), rng=3)  # the same boxes: E is drawn last
    for a, b in zip(svs, plain):
        assert_array_equal(a.boxes_xyxy, b.boxes_xyxy)
    rng = np.random.default_rng(0)
    offsets = np.array([model.hand_eye_error(rng) for _ in range(1500)])
    assert_allclose(offsets[:, :3, 3].std(axis=0), 0.002, rtol=0.08)
    rotvec = Rotation.from_matrix(offsets[:, :3, :3]).as_rotvec()
    assert_allclose(rotvec.std(axis=0), math.radians(0.5), rtol=0.08)
    rng = np.random.default_rng(0)
    assert NoiseModel().hand_eye_error(rng) is None
    assert rng.random() == np.random.default_rng(0).random()  # nothing drawn
