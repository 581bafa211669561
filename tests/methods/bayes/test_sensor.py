"""The bayes sensor model: box-edge noise, inward edge residuals, border censoring (the one home of each)."""

from __future__ import annotations

import numpy as np
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
