"""The compiled box-edge residuals of the ``bayes`` refinement (:func:`box_residuals_fused`).

The twin of the numpy ``_BoxResiduals.batch_numpy`` of :mod:`.refine` (the reference, tested against this):
normalised residuals of observed box edges against the boxes of spheres or upright spheroids, for many
parameter vectors at once (the forward-difference Jacobian's columns in one call).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...kernels.jit import kernel
from ._predict import _in_front, _spheroid_box_px, camera_arrays
from .sensor import UNDEFINED_RESIDUAL, SensorModel


def _box_residuals_kernel(
    R, t, obs, censored, extra2, centres, radii, semi_up, up_opt, cam, code, coeffs, alpha, sigma0, out
):  # pragma: no cover
    P = centres.shape[0]
    M = R.shape[0]
    fx, fy, cx, cy = cam[0], cam[1], cam[2], cam[3]
    for p in range(P):
        r = radii[p]
        b = semi_up[p]
        for m in range(M):
            X = R[m, 0, 0] * centres[p, 0] + R[m, 0, 1] * centres[p, 1] + R[m, 0, 2] * centres[p, 2] + t[m, 0]
            Y = R[m, 1, 0] * centres[p, 0] + R[m, 1, 1] * centres[p, 1] + R[m, 1, 2] * centres[p, 2] + t[m, 1]
            Z = R[m, 2, 0] * centres[p, 0] + R[m, 2, 1] * centres[p, 1] + R[m, 2, 2] * centres[p, 2] + t[m, 2]
            if not _in_front(Z, r, b, up_opt[m, 2]):
                for e in range(4):
                    out[p, 4 * m + e] = UNDEFINED_RESIDUAL
                continue
            px1, py1, px2, py2 = _spheroid_box_px(
                X, Y, Z, r, b, up_opt[m, 0], up_opt[m, 1], up_opt[m, 2], fx, fy, cx, cy, code, coeffs
            )
            sx = alpha * (px2 - px1) + sigma0
            sy = alpha * (py2 - py1) + sigma0
            if extra2[m] != 0.0:
                sx = math.sqrt(sx * sx + extra2[m])
                sy = math.sqrt(sy * sy + extra2[m])
            d0 = obs[m, 0] - px1
            d1 = obs[m, 1] - py1
            d2 = px2 - obs[m, 2]
            d3 = py2 - obs[m, 3]
            if censored[m, 0] and d0 > 0.0:
                d0 = 0.0
            if censored[m, 1] and d1 > 0.0:
                d1 = 0.0
            if censored[m, 2] and d2 > 0.0:
                d2 = 0.0
            if censored[m, 3] and d3 > 0.0:
                d3 = 0.0
            e0 = d0 / sx
            e1 = d1 / sy
            e2 = d2 / sx
            e3 = d3 / sy
            # np.nan_to_num(e, nan=1e3): NaN -> 1e3, +-inf -> +-max float
            out[p, 4 * m] = UNDEFINED_RESIDUAL if math.isnan(e0) else max(min(e0, _FMAX), -_FMAX)
            out[p, 4 * m + 1] = UNDEFINED_RESIDUAL if math.isnan(e1) else max(min(e1, _FMAX), -_FMAX)
            out[p, 4 * m + 2] = UNDEFINED_RESIDUAL if math.isnan(e2) else max(min(e2, _FMAX), -_FMAX)
            out[p, 4 * m + 3] = UNDEFINED_RESIDUAL if math.isnan(e3) else max(min(e3, _FMAX), -_FMAX)


_FMAX = float(np.finfo(np.float64).max)


def box_residuals_fused(
    camera: Camera,
    R_optical_base: NDArray[np.float64],
    t_optical_base: NDArray[np.float64],
    bbox_xyxy: NDArray[np.float64],
    censored: NDArray[np.bool_],
    extra_sigma2_px2: NDArray[np.float64],
    centres_base: NDArray[np.float64],
    radii: NDArray[np.float64],
    model: SensorModel,
    semi_up: NDArray[np.float64] | None = None,
    up_optical: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Normalised box-edge residuals of M observations for P spheres, shape (P, 4 M), in one compiled loop.

    With ``semi_up`` (P,) metres and ``up_optical`` (M, 3) (the symmetry axis in each observation's optical
    frame), the objects are upright spheroids of semi-axes ``radii`` across and ``semi_up`` along the axis.

    The compiled twin of the numpy ``_BoxResiduals.batch_numpy`` of :mod:`.refine` (the reference, tested
    against this): ``R_optical_base`` (M, 3, 3), ``t_optical_base`` (M, 3), ``bbox_xyxy`` (M, 4) pixels,
    ``censored`` (M, 4) edges at the image border, ``extra_sigma2_px2`` (M,) extra edge variance,
    ``centres_base`` (P, 3) metres, ``radii`` (P,) metres.
    """
    cam, code, coeffs = camera_arrays(camera)
    out = np.empty((len(radii), 4 * len(bbox_xyxy)))
    semi_up = radii if semi_up is None else semi_up
    up_optical = np.zeros((len(bbox_xyxy), 3)) if up_optical is None else up_optical
    _box_residuals_kernel(
        np.ascontiguousarray(R_optical_base, dtype=np.float64),
        np.ascontiguousarray(t_optical_base, dtype=np.float64),
        np.ascontiguousarray(bbox_xyxy, dtype=np.float64),
        np.ascontiguousarray(censored, dtype=np.bool_),
        np.ascontiguousarray(extra_sigma2_px2, dtype=np.float64),
        np.ascontiguousarray(centres_base, dtype=np.float64),
        np.ascontiguousarray(radii, dtype=np.float64),
        np.ascontiguousarray(semi_up, dtype=np.float64),
        np.ascontiguousarray(up_optical, dtype=np.float64),
        cam,
        code,
        coeffs,
        float(model.alpha),
        float(model.sigma0_px),
        out,
    )
    return out


_box_residuals_kernel = kernel("bayes", error_model="numpy")(_box_residuals_kernel)
