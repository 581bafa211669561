"""The cut edges of the accuracy benchmark's simulated fruit and the simulator's edge-noise densities."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.bench.leaf_cuts import PAIR_COVARIANCE, edge_noise_density, fruit_boxes, pair_noise_density
from monovisual3d.errors import InputError
from monovisual3d.geometry.bounds import box_edge_covariance

#: Grid of the densities' checks, noise-scale units.
STEP, PAD = 0.05, 8.0


def test_the_pair_covariance_is_the_simulators() -> None:
    C = box_edge_covariance([0.0, 0.0, 1.0, 1.0], 1.0)  # unit box, unit noise: the noise-scale units
    assert_allclose(C[np.ix_([0, 2], [0, 2])], PAIR_COVARIANCE)
    assert_allclose(C[np.ix_([1, 3], [1, 3])], PAIR_COVARIANCE)


def test_the_densities_integrate_to_one_and_agree() -> None:
    ax, u, density = pair_noise_density(STEP, PAD)
    assert u.shape == (len(ax), len(ax), 2) and density.shape == (len(ax), len(ax))
    assert_allclose(density.sum() * STEP**2, 1.0, atol=1e-6)
    assert_allclose(density.sum(axis=1) * STEP, edge_noise_density(ax), atol=1e-6)  # the marginal of one edge
    covariance = np.einsum("ijk,ijl,ij->kl", u, u, density) * STEP**2
    assert_allclose(covariance, PAIR_COVARIANCE, atol=1e-4)


def test_fruit_boxes_of_the_leaf_occlusion_condition() -> None:
    fruit = list(fruit_boxes("greenhouse-noise", range(0, 1)))
    assert fruit and len({(f.seed, f.index) for f in fruit}) == len(fruit)
    for f in fruit:
        V = len(f.T_base_optical)
        assert f.seen.shape == f.boxes.shape == f.full.shape == f.usable.shape == f.cut.shape == (V, 4)
        assert f.J.shape[:2] == (V, 4)
        assert f.depths.shape == (int(f.usable.sum()),) and np.all(f.depths >= 0)
        assert np.count_nonzero(f.depths) == int((f.cut & f.usable).sum())  # a cut edge lies inward, an uncut one at 0
        assert f.known_sq > 0
    assert any(np.any(f.cut) for f in fruit)  # leaves cut some edges of this scene


def test_fruit_boxes_refuses_unknown_conditions() -> None:
    with pytest.raises(InputError, match="condition: got 'nope'"):
        next(fruit_boxes("nope", range(0, 1)))
