"""The paper's kernels and the per-view mixture likelihood, fast vs slow reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import InputError
from monovisual3d.methods.paper.engine.params import KERNELS
from monovisual3d.methods.paper.kernels import (
    gaussian_kernel,
    paper_view_likelihood,
    paper_view_likelihood_slow,
    square_kernel,
)

BOX = np.array([100.0, 50.0, 140.0, 110.0])  # 40 x 60 px, centre (120, 80)


def test_square_kernel_values_edges_included() -> None:
    uv = np.array([[120.0, 80.0], [100.0, 50.0], [140.0, 110.0], [99.999, 80.0], [120.0, 110.001], [np.nan, 80.0]])
    assert_allclose(square_kernel(uv, BOX), [1, 1, 1, 0, 0, 0])


def test_gaussian_kernel_values() -> None:
    # sigma = half the box size: sx = 20 px, sy = 30 px
    uv = np.array([[120.0, 80.0], [140.0, 80.0], [120.0, 50.0], [140.0, 110.0], [100.0, 20.0]])
    expected = [1.0, math.exp(-0.5), math.exp(-0.5), math.exp(-1.0), math.exp(-0.5 - 2.0)]
    assert_allclose(gaussian_kernel(uv, BOX), expected, rtol=1e-12)


def test_gaussian_kernel_sigma_fraction() -> None:
    """The paper's noisy setting: sigma = size / 3."""
    uv = np.array([[140.0, 80.0]])  # du = 20 px, sx = 40 / 3 px
    assert_allclose(gaussian_kernel(uv, BOX, sigma_fraction=1 / 3), [math.exp(-(20.0**2) / (2 * (40 / 3) ** 2))], rtol=1e-12)


@pytest.mark.parametrize("kernel", KERNELS)
def test_nan_behind_camera_scores_zero(kernel: str) -> None:
    uv = np.array([[np.nan, np.nan], [120.0, 80.0]])
    lik = paper_view_likelihood(uv, BOX[None], kernel)
    assert_allclose(lik, [0.0, 1.0])
    assert np.all(np.isfinite(lik))


def test_mixture_is_the_mean_over_boxes() -> None:
    boxes = np.array([[0.0, 0.0, 10.0, 10.0], [5.0, 5.0, 20.0, 20.0], [100.0, 100.0, 110.0, 110.0]])
    uv = np.array([[2.0, 2.0], [7.0, 7.0], [105.0, 105.0], [50.0, 50.0]])
    assert_allclose(paper_view_likelihood(uv, boxes, "square"), [1 / 3, 2 / 3, 1 / 3, 0.0])
    g = paper_view_likelihood(uv, boxes, "gaussian")
    assert_allclose(g, np.mean([gaussian_kernel(uv, b) for b in boxes], axis=0), rtol=1e-12)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("sigma_fraction", [0.5, 1 / 3])
def test_vectorised_matches_slow_reference(kernel: str, sigma_fraction: float, rng: np.random.Generator) -> None:
    """Tiny grid projected into a view: random pixels (some behind the camera), several boxes."""
    uv = rng.uniform(-50.0, 700.0, (300, 2))
    uv[rng.random(300) < 0.2] = np.nan
    x1y1 = rng.uniform(0.0, 500.0, (4, 2))
    boxes = np.column_stack([x1y1, x1y1 + rng.uniform(5.0, 150.0, (4, 2))])
    uv[:4] = boxes[:, :2]  # exactly on box corners: edges count as inside for both
    fast = paper_view_likelihood(uv, boxes, kernel, sigma_fraction)
    slow = paper_view_likelihood_slow(uv, boxes, kernel, sigma_fraction)
    assert fast.shape == (300,)
    assert_allclose(fast, slow, rtol=1e-12, atol=1e-300)
    assert np.all(fast[np.isnan(uv[:, 0])] == 0)
    assert fast.max() > 0  # the comparison is not between two zero arrays


def test_single_box_may_be_given_flat() -> None:
    uv = np.array([[120.0, 80.0]])
    assert_allclose(paper_view_likelihood(uv, BOX, "square"), [1.0])


def test_bad_kernel_and_no_boxes() -> None:
    uv = np.zeros((1, 2))
    with pytest.raises(InputError, match=r"^kernel: got 'box', expected one of \['square', 'gaussian'\]"):
        paper_view_likelihood(uv, BOX, "box")
    with pytest.raises(InputError, match=r"a view needs at least one box"):
        paper_view_likelihood(uv, np.zeros((0, 4)), "square")
