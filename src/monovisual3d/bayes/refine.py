"""Continuous refinement of one sphere from its associated boxes (and masks).

Robust nonlinear least squares (:func:`scipy.optimize.least_squares`) on the
normalised box-edge residuals of :mod:`.likelihood`, with a redescending loss
that matches the sensor model: ``rho(z) = -2 log((exp(-z/2) + eps) / (1 + eps))``
with ``eps = exp(-inward_floor)``. Near zero it is the ordinary square; an
edge more than ~3 sigma off (occluded, truncated) stops pulling the estimate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from ..camera import Camera
from ..frames import invert_transform
from .likelihood import SensorModel, edge_residuals, predict_boxes
from .masks import mask_residuals


@dataclass
class Observation:
    """One associated detection: the view's ``T_optical_base``, its box, and optional mask contour points."""

    T_optical_base: NDArray[np.float64]
    bbox_xyxy: NDArray[np.float64]
    contour_uv: NDArray[np.float64] | None = None


@dataclass
class Refined:
    """Refined sphere: centre (3,) metres base frame, radius metres, position covariance (3, 3) m^2, cost."""

    centre: NDArray[np.float64]
    radius: float
    covariance: NDArray[np.float64]
    radius_std: float
    cost: float
    success: bool


def _loss(floor: float):
    eps = float(np.exp(-floor))

    def rho(z: NDArray[np.float64]) -> NDArray[np.float64]:
        g = np.exp(-0.5 * z)
        out = np.empty((3, len(z)))
        out[0] = -2.0 * (np.log(g + eps) - np.log1p(eps))
        out[1] = g / (g + eps)
        out[2] = -0.5 * g * eps / (g + eps) ** 2
        return out

    return rho


def residuals(
    params: NDArray[np.floating], camera: Camera, observations: Sequence[Observation], model: SensorModel, use_masks: bool = True
) -> NDArray[np.float64]:
    """Stacked normalised residuals for ``params = (x, y, z, log r)`` (base frame, metres)."""
    c = params[:3]
    r = float(np.exp(params[3]))
    out = []
    for ob in observations:
        p_opt = ob.T_optical_base[:3, :3] @ c + ob.T_optical_base[:3, 3]
        if use_masks and ob.contour_uv is not None:
            out.append(mask_residuals(camera, p_opt, r, ob.contour_uv, model))
            continue
        pred, _ = predict_boxes(camera, p_opt[None, :], np.array([r]))
        e = edge_residuals(pred[0, 0], ob.bbox_xyxy, model, camera.width, camera.height)
        out.append(np.nan_to_num(e, nan=1e3))
    return np.concatenate(out) if out else np.zeros(0)


def refine_sphere(
    camera: Camera,
    observations: Sequence[Observation],
    centre0: NDArray[np.floating],
    radius0: float,
    model: SensorModel,
    *,
    use_masks: bool = True,
) -> Refined:
    """Refine centre and radius from at least two associated observations.

    Returns
    -------
    Refined
        ``covariance`` is ``(J^T W J)^-1`` at the solution (W: the loss's
        inlier weights), the Gauss-Newton approximation of the posterior
        covariance of the position.
    """
    x0 = np.concatenate([np.asarray(centre0, dtype=float), [np.log(max(radius0, 1e-4))]])
    fun = lambda p: residuals(p, camera, observations, model, use_masks)  # noqa: E731
    sol = least_squares(fun, x0, loss=_loss(model.inward_floor), method="trf", x_scale=np.array([0.01, 0.01, 0.01, 0.1]))
    f = sol.fun
    w = _loss(model.inward_floor)(f * f)[1]
    J = sol.jac
    H = J.T @ (w[:, None] * J)
    try:
        cov_full = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        cov_full = np.full((4, 4), np.nan)
    r = float(np.exp(sol.x[3]))
    return Refined(
        centre=sol.x[:3].copy(),
        radius=r,
        covariance=cov_full[:3, :3],
        radius_std=float(r * np.sqrt(max(cov_full[3, 3], 0.0))) if np.isfinite(cov_full[3, 3]) else float("nan"),
        cost=float(sol.cost),
        success=bool(sol.success),
    )


def observation_for(
    view_T_base_optical: NDArray[np.floating], bbox: NDArray[np.floating], contour: NDArray[np.floating] | None
) -> Observation:
    return Observation(invert_transform(view_T_base_optical), np.asarray(bbox, dtype=float), contour)
