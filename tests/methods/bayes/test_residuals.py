"""The compiled box residuals (``methods/bayes/_residuals.py``) where the edge noise vanishes."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal

from monovisual3d.camera import Camera
from monovisual3d.geometry.sphere import predict_sphere_boxes
from monovisual3d.methods.bayes._predict import camera_arrays
from monovisual3d.methods.bayes._residuals import _box_residuals_kernel
from monovisual3d.methods.bayes.sensor import inward_edge_offsets

CAM = Camera(640, 480, 480, 470, 322, 238)


def test_a_zero_noise_scale_gives_the_numpy_twins_limits_not_an_error():
    # A refinement step once met a predicted box whose edge noise was 0, and numba's default (Python) error model
    # raised ZeroDivisionError out of localize. The numpy twin divides to +-inf (then the largest float) and 0 / 0
    # to NaN (then 1e3): the kernel must do the same, here with the noise set to 0 outright.
    cam, code, coeffs = camera_arrays(CAM)
    centre, radius = np.array([[0.01, -0.02, 0.5]]), np.array([0.02])
    pred = predict_sphere_boxes(CAM, centre, radius)[0][0, 0]
    obs = pred + np.array([[-3.0, 2.0, 0.0, 5.0]])  # left edge outside, top inside, right exact, bottom outside
    out = np.empty((1, 4))
    no_axis, no_censoring = np.zeros((1, 3)), np.zeros((1, 4), dtype=bool)
    pose = (np.eye(3)[None], np.zeros((1, 3)))
    alpha = sigma0_px = 0.0
    _box_residuals_kernel(
        *pose, obs, no_censoring, np.zeros(1), centre, radius, radius, no_axis, cam, code, coeffs, alpha, sigma0_px, out
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = np.nan_to_num(inward_edge_offsets(pred[None], obs) / 0.0, nan=1e3)
    assert_array_equal(out, expected)
    largest = np.finfo(np.float64).max
    assert_array_equal(out[0], [-largest, largest, 1e3, -largest])  # the signs of the inward offsets
