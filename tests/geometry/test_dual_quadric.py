"""Dual quadrics of ellipsoids and back (:mod:`monovisual3d.geometry.quadric`)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.errors import InputError
from monovisual3d.geometry.quadric import dual_quadric, ellipsoid_from_dual_quadric


def test_ellipsoid_from_dual_quadric_inverts_dual_quadric(rng: np.random.Generator) -> None:
    for _ in range(5):
        c, s = rng.normal(size=3), rng.uniform(0.01, 0.2, 3)
        R = Rotation.random(random_state=rng.integers(1 << 31)).as_matrix()
        centre, semi, R_hat = ellipsoid_from_dual_quadric(-rng.uniform(0.1, 10) * dual_quadric(c, s, R))
        assert_allclose(centre, c, atol=1e-12)
        assert_allclose(semi, np.sort(s), rtol=1e-9)
        assert_allclose(dual_quadric(centre, semi, R_hat), dual_quadric(c, s, R), atol=1e-12)
        assert np.linalg.det(R_hat) > 0


@pytest.mark.parametrize(
    ("Q", "pattern"),
    [
        (np.diag([1.0, 1.0, -1.0, -1.0]), "not an ellipsoid"),
        (np.diag([1.0, 1.0, 1.0, 0.0]), "centre lies at infinity"),
        (np.full((4, 4), np.nan), "finite 4 x 4"),
        (np.arange(16.0).reshape(4, 4), "symmetric"),
    ],
)
def test_ellipsoid_from_dual_quadric_rejects_what_is_not_an_ellipsoid(Q: np.ndarray, pattern: str) -> None:
    with pytest.raises(InputError, match=pattern):
        ellipsoid_from_dual_quadric(Q)
