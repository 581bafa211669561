"""The box of a sampled curve: few samples refined by a parabola against the dense samples' own box."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from monovisual3d.bench.trust_cases import path_camera
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.curve_box import dense_curve_box, sampled_curve_box
from monovisual3d.geometry.ellipsoid import ellipsoid_bbox
from monovisual3d.geometry.solids import cuboid_bbox, cylinder_bbox

#: Dense samples of the reference, and the largest difference (pixels) allowed from it: far below box noise.
DENSE = 20000
TOL_PX = 0.005


def test_an_ellipse_box_from_few_samples() -> None:
    t = np.linspace(0.0, 2 * np.pi, 48, endpoint=False)
    uv = np.stack([100 + 50 * np.cos(t + 0.3), 80 + 30 * np.sin(t + 0.3)], axis=-1)
    assert_allclose(sampled_curve_box(uv, closed=True), [50, 50, 150, 110], atol=1e-3)
    assert np.abs(dense_curve_box(uv) - [50, 50, 150, 110]).max() > 0.01  # the unrefined samples are further off


def test_an_open_arc_keeps_its_ends_and_nan_stays_nan() -> None:
    uv = np.stack([np.linspace(0, 10, 5), np.linspace(0, 10, 5) ** 2 / 10], axis=-1)  # monotone: the ends are extreme
    assert_allclose(sampled_curve_box(uv, closed=False), [0, 0, 10, 10])
    uv[2, 0] = np.nan  # a point behind the camera: NaN where the samples' own box is NaN, as the reference
    assert_allclose(sampled_curve_box(uv[None], closed=False), dense_curve_box(uv[None]), equal_nan=True)


def test_solid_boxes_under_distortion_match_the_dense_reference() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        cam = path_camera(rng)
        for coeffs in (cam.distortion_coefficients, tuple(-c for c in cam.distortion_coefficients)):
            c = Camera(cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, "plumb_bob", coeffs)
            target = rng.uniform(-0.3, 0.3, 3) + [1.0, 0.0, 0.0]
            T = look_at([0.0, 0.0, 0.0], target + rng.normal(0.0, 0.15, 3))
            R = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
            s = rng.uniform(0.02, 0.08, 3)
            assert_allclose(
                ellipsoid_bbox(c, T, target, s, R, clip=False),
                ellipsoid_bbox(c, T, target, s, R, clip=False, n_contour=DENSE),
                atol=TOL_PX,
            )
            assert_allclose(
                cylinder_bbox(c, T, target, s[0], s[2], R),
                cylinder_bbox(c, T, target, s[0], s[2], R, n_contour=DENSE),
                atol=TOL_PX,
            )
            assert_allclose(cuboid_bbox(c, T, target, s, R), cuboid_bbox(c, T, target, s, R, n_contour=DENSE // 10), atol=TOL_PX)
