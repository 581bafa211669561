"""Cramer-Rao bound of the ellipsoid box model."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.bench.accuracy import crlb_rms_sq
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.geometry import Ellipsoid
from monovisual3d.geometry.bounds import (
    box_edge_covariance,
    centre_crlb_rms_sq,
    cut_edges,
    ellipsoid_box_jacobian,
    ellipsoid_crlb,
    shape_parameters,
)
from monovisual3d.sim.scenes import default_camera, paper_scene
from monovisual3d.sim.simulate import simulate_views
from monovisual3d.sim.viewpoints import paper_poses

CAM = default_camera()
CUCUMBER = Ellipsoid.upright([0.6, 0.02, 0.45], [0.025, 0.02, 0.09], 0.4)


def test_sphere_model_equals_the_sphere_bound_of_the_accuracy_benchmark() -> None:
    scene = paper_scene()
    svs = simulate_views(scene, rng=0)
    want = crlb_rms_sq(scene, svs, 0.05)
    objects = [Ellipsoid.sphere(c, r) for c, r in zip(scene.centres, scene.radii)]
    poses = [[sv.T_base_optical_true for sv in svs if i in sv.source] for i in range(len(objects))]
    got = centre_crlb_rms_sq(CAM, objects, poses, 0.05, "sphere")
    assert_allclose(got, want, rtol=1e-6)


def test_bound_scales_with_noise_and_shrinks_with_views() -> None:
    P = paper_poses()
    b1 = ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "ellipsoid")
    b2 = ellipsoid_crlb(CAM, P, CUCUMBER, 0.10, "ellipsoid")
    assert b1.names == ("x", "y", "z", "a", "b", "c", "yaw")
    assert np.all(np.isfinite(b1.covariance)) and b1.n_views == 3
    assert_allclose(b2.covariance, 4 * b1.covariance, rtol=1e-6)  # covariance ~ sigma^2
    ring = np.stack(
        [
            look_at(0.6 * np.array([1 - np.cos(a), np.sin(a), 0]) + [0, 0, 0.45], CUCUMBER.centre_base)
            for a in np.linspace(-0.6, 0.6, 7)
        ]
    )
    b7 = ellipsoid_crlb(CAM, np.concatenate([P, ring]), CUCUMBER, 0.05, "ellipsoid")
    assert b7.centre_rms_sq < b1.centre_rms_sq
    # a richer model cannot know the centre better than a poorer one on the same object (nested models)
    spheroid = Ellipsoid.spheroid(CUCUMBER.centre_base, 0.022, 0.09)
    s = ellipsoid_crlb(CAM, P, spheroid, 0.05, "spheroid")
    e = ellipsoid_crlb(CAM, P, spheroid, 0.05, "ellipsoid")
    assert s.centre_rms_sq <= e.centre_rms_sq * (1 + 1e-9)
    assert 0 < s.size_rms < 0.01


def test_invisible_yaw_of_a_body_of_revolution_is_left_out() -> None:
    spheroid = Ellipsoid.spheroid([0.6, 0.0, 0.45], 0.03, 0.05)
    b = ellipsoid_crlb(CAM, paper_poses(), spheroid, 0.05, "ellipsoid")
    assert np.isnan(b.covariance[-1]).all()  # yaw
    assert np.all(np.isfinite(b.covariance[:6, :6]))
    free = ellipsoid_crlb(CAM, paper_poses(), spheroid, 0.05, "spheroid", free_orientation=True)
    assert free.names[-2:] == ("tilt_a", "tilt_b") and np.all(np.isfinite(free.covariance))


def test_clipped_edges_carry_no_information() -> None:
    P = paper_poses()
    boxes, J = ellipsoid_box_jacobian(CAM, P, CUCUMBER, "spheroid")
    assert boxes.shape == (3, 4) and J.shape == (3, 4, 5)
    # numerical derivative of the centre's x in the first view's image: moving the object moves the box
    assert np.abs(J[:, :, :3]).max() > 100
    # a view so close that the object fills the whole image: every edge is clipped, the view is ignored
    near = look_at([0.57, 0.02, 0.45], CUCUMBER.centre_base)
    b = ellipsoid_crlb(CAM, np.concatenate([P, near[None]]), CUCUMBER, 0.05)
    assert b.n_views == 3
    assert_allclose(b.fisher, ellipsoid_crlb(CAM, P, CUCUMBER, 0.05).fisher, rtol=1e-12)
    one = ellipsoid_crlb(CAM, P[:1], CUCUMBER, 0.05)
    assert np.isnan(one.covariance).all()  # one view cannot fix seven parameters


def test_cut_edges_are_those_inside_the_full_box() -> None:
    full = np.array([[100.0, 50.0, 180.0, 250.0], [10.0, 20.0, 30.0, 40.0]])
    seen = full + np.array([[1.0, 30.0, -1.0, 0.0], [0.0, 0.0, -5.0, -1.6]])
    assert_allclose(cut_edges(full, seen), [[False, True, False, False], [False, False, True, True]])
    assert not cut_edges(full, full).any()


def test_an_occluded_edge_raises_the_bound() -> None:
    P = paper_poses()
    boxes, _ = ellipsoid_box_jacobian(CAM, P, CUCUMBER, "spheroid")
    full = ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "spheroid")
    # stating the full boxes as the noise's boxes and no cut edge changes nothing
    same = ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "spheroid", censored=np.zeros((3, 4), bool), noise_boxes_xyxy=boxes)
    assert_allclose(same.fisher, full.fisher, rtol=1e-12)
    censored = np.zeros((3, 4), bool)
    censored[1, 0] = True  # a leaf cuts the left edge in the second view
    cut = ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "spheroid", censored=censored, noise_boxes_xyxy=boxes)
    assert cut.centre_rms_sq > full.centre_rms_sq * (1 + 1e-3)
    # the information lost is that of the cut edge: F_full - F_cut is positive semi-definite
    assert np.linalg.eigvalsh(full.fisher - cut.fisher).min() > -1e-9 * np.abs(full.fisher).max()
    # every edge of a view cut: the view is ignored
    all_cut = np.zeros((3, 4), bool)
    all_cut[2] = True
    assert ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "spheroid", censored=all_cut).n_views == 2


def test_smaller_visible_box_means_smaller_relative_noise() -> None:
    P = paper_poses()
    boxes, _ = ellipsoid_box_jacobian(CAM, P, CUCUMBER, "spheroid")
    half = boxes.copy()
    half[:, 0] = 0.5 * (boxes[:, 0] + boxes[:, 2])  # the left half hidden: the detector's box is half as wide
    censored = np.zeros((3, 4), bool)
    censored[:, 0] = True
    wide = ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "spheroid", censored=censored, noise_boxes_xyxy=boxes)
    narrow = ellipsoid_crlb(CAM, P, CUCUMBER, 0.05, "spheroid", censored=censored, noise_boxes_xyxy=half)
    assert narrow.centre_rms_sq < wide.centre_rms_sq


def test_edge_covariance_matches_the_simulator_noise() -> None:
    rng = np.random.default_rng(0)
    from monovisual3d.sim.noise import NoiseModel

    box = np.array([100.0, 50.0, 180.0, 250.0])
    draws = np.array([NoiseModel(box_sigma=0.05).apply_to_boxes(box[None], (640, 480), rng)[0][0] for _ in range(4000)])
    assert_allclose(np.cov(draws.T), box_edge_covariance(box, 0.05), atol=0.1 * 0.05**2 * 200**2)
    assert_allclose(box_edge_covariance(box, 0.0, 2.0), 4.0 * np.eye(4))


def test_bad_input() -> None:
    with pytest.raises(InputError, match="model: got 'cube'"):
        shape_parameters("cube")
    with pytest.raises(InputError, match="expected >= 0 and not both 0"):
        ellipsoid_crlb(CAM, paper_poses(), CUCUMBER, 0.0)
    with pytest.raises(InputError, match="poses: got 1 pose lists for 2 objects"):
        centre_crlb_rms_sq(CAM, [CUCUMBER, CUCUMBER], [paper_poses()], 0.05)
    with pytest.raises(InputError, match=r"censored, noise_boxes_xyxy: expected shape \(3, 4\)"):
        ellipsoid_crlb(CAM, paper_poses(), CUCUMBER, 0.05, censored=np.zeros((2, 4), bool))
