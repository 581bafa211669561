"""The one camera packing and the one compiled distortion, against ``Camera.project`` (the numpy reference)."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.camera import DISTORTION_IDS, Camera, PackedCamera
from monovisual3d.kernels import project
from monovisual3d.methods.bayes._kernels import cone_counts_fused
from monovisual3d.methods.bayes._predict import camera_arrays

#: One camera per distortion model (and both plumb_bob lengths), coefficients of a real wide lens.
CAMERAS = {
    "none": Camera(640, 480, 500.0, 510.0, 321.0, 239.0),
    "plumb_bob4": Camera(640, 480, 500.0, 510.0, 321.0, 239.0, "plumb_bob", (-0.28, 0.07, 1e-3, -2e-3)),
    "plumb_bob5": Camera(640, 480, 500.0, 510.0, 321.0, 239.0, "radtan", (-0.28, 0.07, 1e-3, -2e-3, 0.01)),
    "rational": Camera(
        640, 480, 500.0, 510.0, 321.0, 239.0, "rational_polynomial", (0.5, -0.1, 1e-3, -2e-3, 0.02, 0.8, 0.05, 0.01)
    ),
    "equidistant": Camera(640, 480, 300.0, 300.0, 320.0, 240.0, "fisheye", (0.05, -0.01, 0.003, -0.0005)),
}


@numba.njit
def _distort_rows(model, d, xy, one):  # pragma: no cover - compiled
    out = np.empty_like(xy)
    for n in range(xy.shape[0]):
        x, y = project.distort_xy(xy[n, 0], xy[n, 1], model, d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], one)
        out[n, 0] = x
        out[n, 1] = y
    return out


def _points_optical(rng: np.random.Generator, n: int) -> np.ndarray:
    """Points 0.3-3 m in front of the camera, normalised coordinates in [-0.7, 0.7]."""
    z = rng.uniform(0.3, 3.0, n)
    xy = rng.uniform(-0.7, 0.7, (n, 2))
    return np.column_stack([xy * z[:, None], z])


def test_one_distortion_table():
    assert sorted(DISTORTION_IDS.values()) == [0, 1, 2, 3]
    # the bayes kernels read the same packing
    cam = CAMERAS["rational"]
    c, code, coeffs = camera_arrays(cam)
    p = cam.packed()
    assert code == p.distortion_id == DISTORTION_IDS["rational_polynomial"]
    assert_allclose(coeffs, p.distortion)
    assert_allclose(c, [cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height])


@pytest.mark.parametrize("name", list(CAMERAS))
def test_packed_fields(name):
    cam = CAMERAS[name]
    p = cam.packed()
    assert isinstance(p, PackedCamera)
    assert p.intrinsics.shape == (4,) and p.intrinsics.dtype == np.float64
    assert p.distortion.shape == (8,) and p.distortion.dtype == np.float64
    assert p.distortion_id == DISTORTION_IDS[cam.distortion_model]
    assert (p.width, p.height) == (640, 480)
    n = len(cam.distortion_coefficients)
    assert_allclose(p.distortion[:n], cam.distortion_coefficients)
    assert not p.distortion[n:].any()


@pytest.mark.parametrize("name", list(CAMERAS))
def test_compiled_distortion_matches_numpy(name):
    cam = CAMERAS[name]
    rng = np.random.default_rng(7)
    xy = rng.uniform(-0.7, 0.7, (500, 2))
    xy[0] = 0.0  # the centre (equidistant: r = 0)
    p = cam.packed()
    expected = cam.distort(xy)
    assert_allclose(_distort_rows(p.distortion_id, p.distortion, xy, 1.0), expected, rtol=1e-12, atol=1e-14)
    if p.distortion_id != DISTORTION_IDS["equidistant"]:  # float32 rows (the fast Gaussian path)
        got32 = _distort_rows(p.distortion_id, p.distortion.astype(np.float32), xy.astype(np.float32), np.float32(1.0))
        assert got32.dtype == np.float32
        assert_allclose(got32, expected, rtol=0, atol=2e-6)


@pytest.mark.parametrize("name", list(CAMERAS))
def test_compiled_projections_match_camera_project(name):
    cam = CAMERAS[name]
    rng = np.random.default_rng(11)
    p_optical = _points_optical(rng, 400)
    p_optical[-3:, 2] = [-0.5, 0.0, -2.0]  # behind or on the camera plane
    uv_ref = cam.project(p_optical)
    p = cam.packed()
    T = np.zeros((1, 3, 4))
    T[0, :, :3] = np.eye(3)  # grid frame = optical frame
    intr = p.intrinsics[None]
    dists = p.distortion[None]
    n = len(p_optical)
    front = p_optical[:, 2] > 0
    # scalar twin
    uv_point = np.array([project.project_point(T, intr, dists, 0, p.distortion_id, *q) for q in p_optical])
    assert_allclose(uv_point[front], uv_ref[front], rtol=1e-12, atol=1e-9)
    assert (uv_point[~front] == project.FAR_PX).all()
    # row kernels: points as res * offsets from a corner
    res = 0.01
    F = p_optical / res
    kernels = (
        (project.project_cells, np.float64, {"rtol": 1e-12, "atol": 1e-8}),
        (project.project_cells32, np.float32, {"rtol": 0, "atol": 0.05}),
    )
    for kernel, dtype, tolerance in kernels:
        Fd = F.astype(dtype)
        ub, vb = np.empty(n, dtype), np.empty(n, dtype)
        corner = (0.0, 0.0, 0.0)
        kernel(T[0], p.intrinsics, p.distortion_id, p.distortion, *corner, res, n, *(Fd[:, c].copy() for c in range(3)), ub, vb)
        assert_allclose(np.column_stack([ub, vb])[front], uv_ref[front], **tolerance)
        if dtype == np.float64:
            assert (ub[~front] == project.FAR_PX).all()


@pytest.mark.parametrize("name", ["none", "rational", "equidistant"])
def test_bayes_cone_kernel_uses_the_same_projection(name):
    """A point counts in a view exactly when its ``Camera.project`` pixel falls inside a (widened) box."""
    cam = CAMERAS[name]
    rng = np.random.default_rng(3)
    p_optical = _points_optical(rng, 300)
    uv = cam.project(p_optical)
    # a 1-px box around each of the first 10 points' pixels, not widened: those points count, far ones not
    boxes = np.column_stack([uv[:10] - 0.5, uv[:10] + 0.5])
    counts = cone_counts_fused(cam, [np.eye(4)], [boxes], p_optical, half_diagonal=0.0, widen=0.0)
    inside = np.zeros(len(p_optical), bool)
    for b in boxes:
        # cone_counts adds a 2 px margin around each box
        inside |= (uv[:, 0] >= b[0] - 2) & (uv[:, 0] <= b[2] + 2) & (uv[:, 1] >= b[1] - 2) & (uv[:, 1] <= b[3] + 2)
    assert counts[:10].tolist() == [1] * 10
    np.testing.assert_array_equal(counts.astype(bool), inside)
