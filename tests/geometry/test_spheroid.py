"""Predicted boxes of spheroids: every centre against every bin, or each centre with its own bins."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal

from monovisual3d import Camera
from monovisual3d.geometry.spheroid import predict_spheroid_boxes


def test_each_centre_with_its_own_shape_is_the_diagonal_of_every_centre_against_every_shape():
    """Radii, semi-axes (N, 1) and axes (N, 1, 3) give each centre's box with its own shape: exactly the diagonal of the
    (N, N) call with the same shapes as bins (spheres among them, upright and lying axes, one centre behind the
    camera), with and without lens distortion."""
    rng = np.random.default_rng(3)
    n = 30
    p = np.column_stack([rng.uniform(-0.3, 0.3, (n, 2)), rng.uniform(0.4, 1.0, n)])
    p[4, 2] = -0.5
    radii = rng.uniform(0.01, 0.05, n)
    semi_up = np.where(rng.random(n) < 0.3, radii, rng.uniform(0.01, 0.1, n))  # some spheres
    axes = np.where(rng.random((n, 1)) < 0.5, [0.0, -1.0, 0.0], [1.0, 0.0, 0.0])  # upright (optical -y) or lying
    for cam in (
        Camera.from_hfov(640, 480, 69.0),
        Camera(640, 480, 500.0, 500.0, 320.0, 240.0, "plumb_bob", (0.1, -0.05, 0.001, 0.002)),
    ):
        every, seen_every = predict_spheroid_boxes(cam, p, radii, semi_up, axes)
        own, seen_own = predict_spheroid_boxes(cam, p, radii[:, None], semi_up[:, None], axes[:, None])
        mine = np.arange(n)
        assert own.shape == (n, 1, 4)
        assert_array_equal(own[:, 0], every[mine, mine])
        assert_array_equal(seen_own[:, 0], seen_every[mine, mine])
        assert np.isnan(own[4]).all() and np.isfinite(own[:4, 0]).all()
