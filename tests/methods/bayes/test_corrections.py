"""The correction fits: each model recovers a known simulated error from the boxes, and stays near zero on clean ones."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from monovisual3d.camera import Camera
from monovisual3d.frames import invert_transform
from monovisual3d.methods.bayes.correction_boxes import synthetic_boxes
from monovisual3d.methods.bayes.corrections import (
    MODELS,
    compare_corrections,
    distortion_shift,
    fit_correction,
    hand_eye_summary,
    noise_scale,
    rotation_matrices,
    rotvec_from_matrix,
    view_velocities,
)
from monovisual3d.sim.mistakes import hand_eye_offset
from monovisual3d.sim.scenes import default_camera, random_scene, scene_target
from monovisual3d.sim.viewpoints import arc_poses, hemisphere_poses, ring_poses


def _scene(seed: int = 0, n: int = 8):
    scene = random_scene(n, seed)
    return scene, scene_target(scene)


def test_rotation_matrices_are_rotations_and_match_scipy() -> None:
    rng = np.random.default_rng(0)
    w = rng.normal(size=(5, 3)) * [[0.1], [1.0], [2.0], [1e-9], [0.0]]
    R = rotation_matrices(w)
    assert R.shape == (5, 3, 3)
    assert_allclose(R, Rotation.from_rotvec(w).as_matrix(), atol=1e-12)
    assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)


def test_noise_scale_reads_the_residuals_spread() -> None:
    rng = np.random.default_rng(1)
    assert noise_scale(2.0 * rng.normal(size=4000)) == pytest.approx(2.0, rel=0.05)
    assert noise_scale(0.01 * rng.normal(size=4000)) == pytest.approx(0.25)  # floored
    assert noise_scale(np.zeros(3)) == 1.0  # too few to tell


def test_hand_eye_recovers_a_known_error_from_views_of_diverse_rotation() -> None:
    scene, target = _scene()
    E = hand_eye_offset(2.0, 10.0, rng=5)
    b = synthetic_boxes(
        default_camera(), hemisphere_poses(target, 16, max_angle=math.radians(90)), scene.centres, scene.radii, E=E
    )
    fit = fit_correction(b, "hand_eye")
    s = hand_eye_summary(fit)
    T = np.array(s["T_corrected_reported"])  # p_true = T p_reported; the truth is E
    assert math.degrees(np.linalg.norm(rotvec_from_matrix(T[:3, :3] @ E[:3, :3].T))) < 0.3
    assert np.linalg.norm(T[:3, 3] - E[:3, 3]) < 0.003
    assert s["rotation_deg"] == pytest.approx(2.0, abs=0.3)
    assert_allclose(fit.centres, scene.centres, atol=0.003)


def test_hand_eye_of_a_clean_session_is_near_zero_and_removes_little() -> None:
    scene, target = _scene(1)
    b = synthetic_boxes(default_camera(), ring_poses(target, 6), scene.centres, scene.radii, box_sigma=0.03, rng=2)
    base, tests = compare_corrections(b, list(MODELS))
    for t in tests:
        assert t.chi2_drop < chi2.isf(1e-3, t.dof), t.model
    assert base.model == "none" and base.chi2 > 0


def _path_views(offset_views: float, accel: float = 0.15, n: int = 6):
    """Views along an arc whose speed grows, the poses reported ``offset_views`` views late."""
    scene, target = _scene(2, 7)

    def path(at):
        at = np.asarray(at, dtype=float)
        return arc_poses(target, n, span=math.radians(60), at=at + accel * at * at)

    k = np.arange(n, dtype=float)
    return scene, path(k), path(k + offset_views)


def test_view_velocities_follow_the_path() -> None:
    _, true, _ = _path_views(0.0, accel=0.0)
    T_ob = np.stack([invert_transform(T) for T in true])
    vel = view_velocities(T_ob, np.arange(len(true), dtype=float))
    # a constant-speed arc: the same rotation rate at every view
    assert_allclose(np.linalg.norm(vel[:, :3], axis=1), math.radians(60) / 5, rtol=1e-6)


def test_time_offset_recovers_a_known_offset_on_a_path_of_changing_speed() -> None:
    scene, true, reported = _path_views(0.4)
    b = synthetic_boxes(default_camera(), true, scene.centres, scene.radii)
    b = replace(b, T_optical_base=np.stack([invert_transform(T) for T in reported]))
    fit = fit_correction(b, "time_offset")
    assert fit.theta[0] == pytest.approx(0.4, abs=0.08)  # in views (no stamps): 0.4 of a view late


def test_image_geometry_recovers_a_scale_and_offset() -> None:
    scene, target = _scene(3)
    cam = default_camera()
    b = synthetic_boxes(cam, ring_poses(target, 5), scene.centres, scene.radii)
    s, o = np.array([0.97, 0.97]), np.array([-4.0, 9.0])
    xyxy = b.xyxy.copy()
    xyxy[:, [0, 2]] = cam.cx + s[0] * (xyxy[:, [0, 2]] - cam.cx) + o[0]
    xyxy[:, [1, 3]] = cam.cy + s[1] * (xyxy[:, [1, 3]] - cam.cy) + o[1]
    fit = fit_correction(replace(b, xyxy=xyxy), "image_geometry")
    assert_allclose(np.exp(fit.theta[:2]), s, atol=0.01)
    assert_allclose(fit.theta[2:], o, atol=2.0)


def test_radial_distortion_recovers_a_k1_pattern() -> None:
    scene, target = _scene(4)
    cam = Camera.from_hfov(960, 540, 75.0)
    b = synthetic_boxes(cam, hemisphere_poses(target, 8), scene.centres, scene.radii)
    k1 = np.array([[0.08, 0.0, 0.0]])
    x = (b.xyxy[:, [0, 2]] - cam.cx) / cam.fx
    y = (b.xyxy[:, [1, 3]] - cam.cy) / cam.fy
    xyxy = b.xyxy.copy()
    for k, col in enumerate((0, 2)):
        du, _ = distortion_shift(cam, x[None, :, k], y.mean(axis=1)[None], k1)
        xyxy[:, col] += du[0]
    for k, col in enumerate((1, 3)):
        _, dv = distortion_shift(cam, x.mean(axis=1)[None], y[None, :, k], k1)
        xyxy[:, col] += dv[0]
    fit = fit_correction(replace(b, xyxy=xyxy), "radial_distortion")
    assert fit.theta[0] == pytest.approx(0.08, abs=0.015)
    assert_allclose(fit.theta[1:], 0.0, atol=0.005)


def test_unknown_model_is_refused_by_name() -> None:
    scene, target = _scene()
    b = synthetic_boxes(default_camera(), ring_poses(target, 4), scene.centres, scene.radii)
    with pytest.raises(KeyError, match="lens"):
        fit_correction(b, "lens")
