"""The bayes sensor model: box-edge noise, inward edge residuals, border censoring (the one home of each)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from monovisual3d.methods.bayes.sensor import SensorModel, box_edge_sigma_px, censored_edges, inward_edge_offsets


def test_edge_sigma_is_alpha_size_plus_floor() -> None:
    model = SensorModel(alpha=0.05, sigma0_px=1.0)
    boxes = np.array([[100.0, 50.0, 200.0, 250.0]])  # 100 px wide, 200 px tall
    assert_allclose(box_edge_sigma_px(model, boxes), [[6.0, 11.0, 6.0, 11.0]])


def test_extra_noise_adds_in_quadrature() -> None:
    model = SensorModel(alpha=0.0, sigma0_px=3.0)
    boxes = np.zeros((2, 4))
    assert_allclose(box_edge_sigma_px(model, boxes, np.array([4.0, 0.0])), [[5.0] * 4, [3.0] * 4])


def test_inward_offsets_are_positive_inside_the_prediction() -> None:
    pred = np.array([10.0, 20.0, 110.0, 220.0])
    obs = np.array([15.0, 18.0, 100.0, 225.0])  # left and right edges inside, top and bottom outside
    assert_allclose(inward_edge_offsets(pred, obs), [5.0, -2.0, 10.0, -5.0])


def test_inward_offsets_broadcast(rng: np.random.Generator) -> None:
    pred = rng.uniform(0, 600, (7, 3, 4))
    obs = rng.uniform(0, 600, (3, 4))
    expected = np.stack([inward_edge_offsets(pred[i], obs) for i in range(7)])
    assert_allclose(inward_edge_offsets(pred, obs), expected)


def test_censored_edges_on_the_border() -> None:
    obs = np.array([[0.5, 10.0, 639.5, 470.0], [5.0, 0.0, 300.0, 480.0]])
    assert_array_equal(censored_edges(obs, 640, 480, 1.0), [[True, False, True, False], [False, True, False, True]])


@pytest.mark.parametrize("coefficients", [(), (0.15, 0.05, 0.0, 0.0, 0.0), (-0.25, 0.08, 0.001, -0.001, 0.0)])
def test_cell_shift_bounds_the_edge_moves_of_every_point_in_the_cell(rng: np.random.Generator, coefficients) -> None:
    """The gate's cell term: no point of a cell moves a predicted box edge further than cell_shift_px says (spheres
    and spheroids anywhere in a wide image, cells from 1 to 8 cm, with and without lens distortion), and the bound is
    not loose by more than 2x."""
    from monovisual3d.camera import Camera
    from monovisual3d.geometry.spheroid import predict_spheroid_boxes
    from monovisual3d.methods.bayes.sensor import cell_shift_px

    cam = Camera.from_hfov(1280, 720, 90.0)
    if coefficients:
        cam = replace(cam, distortion_model="plumb_bob", distortion_coefficients=coefficients)
    worst = 0.0
    for _ in range(40):
        h = rng.uniform(0.005, 0.04) * np.sqrt(3)
        centre = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.35, 0.35), 1.0]) * rng.uniform(0.4, 1.2)
        radius, semi_up, up = rng.uniform(0.01, 0.06), rng.uniform(0.01, 0.1), np.array([0.0, -1.0, 0.0])
        pred = predict_spheroid_boxes(cam, centre[None], [radius], [semi_up], up)[0][0, 0]
        bound = cell_shift_px(cam, pred, centre[2], h)
        moves = rng.normal(size=(400, 3))
        moves *= h * rng.uniform(0, 1, (400, 1)) ** (1 / 3) / np.linalg.norm(moves, axis=1, keepdims=True)
        moved = predict_spheroid_boxes(cam, centre + moves, [radius], [semi_up], up)[0][:, 0]
        shift = np.abs(moved - pred).max(axis=0)
        assert np.all(shift <= bound + 1e-9)
        worst = max(worst, float((shift / bound).max()))
    assert worst > 0.5, worst


def test_cell_shift_is_zero_for_a_point_and_open_when_the_cell_reaches_the_camera() -> None:
    from monovisual3d.camera import Camera
    from monovisual3d.methods.bayes.sensor import cell_shift_px

    cam = Camera.from_hfov(640, 480, 69.0)
    pred = np.array([[300.0, 200.0, 340.0, 260.0]])
    assert_array_equal(cell_shift_px(cam, pred, 0.5, 0.0), np.zeros((1, 4)))
    assert np.all(np.isinf(cell_shift_px(cam, pred, np.array([0.01]), 0.02)))
    assert_allclose(cell_shift_px(cam, pred, 0.52, 0.02)[0, 0], max(cam.fx, cam.fy) * 0.02 / 0.5 * np.hypot(1, 20 / cam.fx))
