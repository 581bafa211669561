"""Building blocks of the fused kernels: exp, interval bounds of distortion and projection."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from conftest import DISTORTIONS, make_camera
from monovisual3d.camera import DISTORTION_IDS, distort_normalised
from monovisual3d.methods.paper.engine import numba_kernels as nk
from monovisual3d.methods.paper.engine.params import box_params_from_xyxy, gauss_q_cut


def test_exp_neg_matches_numpy_to_1e12():
    q = np.linspace(0.0, nk.EXP_NEG_MAX, 20001)
    out = np.array([nk.exp_neg(x) for x in q[::50]])
    assert_allclose(out, np.exp(-q[::50]), rtol=1e-12, atol=0)


def test_exp_neg32_matches_numpy_to_2e7():
    q = np.linspace(0.0, 40.0, 4001).astype(np.float32)
    out = np.array([nk.exp_neg32(x) for x in q])  # float32 arithmetic inside, returned as a Python float
    assert_allclose(out, np.exp(-q.astype(np.float64)), rtol=2e-7, atol=0)


def test_gauss_cutoff_bound():
    assert gauss_q_cut(1e-12) == pytest.approx(-np.log(1e-12))
    with pytest.raises(ValueError, match="gauss_eps"):
        gauss_q_cut(1e-20)
    # the support rectangle contains the whole ellipse q <= q_cut
    params, reach = box_params_from_xyxy(np.array([[100.0, 50.0, 140.0, 70.0]]), "gaussian", 0.5, 27.0)
    cu, cv, a, b = params[0]
    t = np.linspace(0, 2 * np.pi, 1000)
    u, v = cu + np.sqrt(27.0 / a) * np.cos(t), cv + np.sqrt(27.0 / b) * np.sin(t)
    assert np.all((u >= reach[0, 0] - 1e-9) & (u <= reach[0, 2] + 1e-9) & (v >= reach[0, 1] - 1e-9) & (v <= reach[0, 3] + 1e-9))


@pytest.mark.parametrize("name", sorted(DISTORTIONS))
def test_distort_bounds_contain_every_point(name, rng):
    cam = make_camera(name)
    model = DISTORTION_IDS[cam.distortion_model]
    d = np.zeros((1, 8))
    d[0, : len(cam.distortion_coefficients)] = cam.distortion_coefficients
    for _ in range(200):
        c = rng.uniform(-2.0, 2.0, 2)
        h = rng.uniform(0.0, 0.5, 2)
        ok, xl, xh, yl, yh = nk.distort_bounds(model, d, 0, c[0] - h[0], c[0] + h[0], c[1] - h[1], c[1] + h[1])
        if not ok:
            continue
        pts = c + h * rng.uniform(-1, 1, (300, 2))
        pts = np.concatenate([pts, c + h * np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]])])
        xd = distort_normalised(pts, cam.distortion_model, cam.distortion_coefficients)
        tol = 1e-9 * (1 + np.abs(xd).max())
        assert np.all(xd[:, 0] >= xl - tol) and np.all(xd[:, 0] <= xh + tol)
        assert np.all(xd[:, 1] >= yl - tol) and np.all(xd[:, 1] <= yh + tol)


@pytest.mark.parametrize("name", ["none", "strong", "equidistant"])
def test_pixel_bounds_contain_projections(name, rng):
    cam = make_camera(name)
    d = np.zeros((1, 8))
    d[0, : len(cam.distortion_coefficients)] = cam.distortion_coefficients
    intr = np.array([[cam.fx, cam.fy, cam.cx, cam.cy]])
    T = np.eye(4)[None, :3].copy()
    for _ in range(100):
        lo = rng.uniform([-0.4, -0.4, 0.05], [0.4, 0.4, 1.0])
        hi = lo + rng.uniform(0.0, 0.1, 3)
        ok, ul, uh, vl, vh = nk.pixel_bounds(
            T, intr, d, 0, DISTORTION_IDS[cam.distortion_model], lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
        )
        assert ok
        p = lo + (hi - lo) * rng.uniform(0, 1, (500, 3))
        uv = cam.project(p)
        tol = 1e-7 * (1 + np.abs(uv).max())
        assert np.all(uv[:, 0] >= ul - tol) and np.all(uv[:, 0] <= uh + tol)
        assert np.all(uv[:, 1] >= vl - tol) and np.all(uv[:, 1] <= vh + tol)


def test_pixel_bounds_refuses_boxes_reaching_the_camera_plane():
    d = np.zeros((1, 8))
    intr = np.array([[500.0, 500.0, 320.0, 240.0]])
    T = np.eye(4)[None, :3].copy()
    ok, *_ = nk.pixel_bounds(T, intr, d, 0, 0, -0.1, 0.1, -0.1, 0.1, -0.05, 0.2)
    assert not ok
