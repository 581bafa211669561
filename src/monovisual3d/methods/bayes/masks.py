"""Instance masks as observations: the silhouette residual.

Mask decoding and outline points live in :mod:`monovisual3d.masks`. For a
sphere, the outline points on the true silhouette lie at the silhouette's
angular radius ``asin(r / |c|)`` from the centre's viewing ray, while outline
points made by an occluder lie inside it: the robust loss of :mod:`.refine`
ignores those. A mask therefore constrains the sphere even where its box is
truncated by an occluder.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from .sensor import UNDEFINED_RESIDUAL


def mask_residuals(
    camera: Camera,
    p_optical: NDArray[np.floating],
    radius: float,
    contour_uv: NDArray[np.floating],
    model: Any,
    extra_sigma_px: float = 0.0,
) -> NDArray[np.float64]:
    """Normalised residuals of contour points against a sphere's silhouette, shape (M,).

    Residual = (angle between the point's viewing ray and the centre's ray minus
    the silhouette's angular radius) * focal length / sigma, with sigma as for a
    box edge of the predicted silhouette's size (and ``extra_sigma_px``, pixels,
    added in quadrature). Positive: point outside the silhouette.
    """
    p = np.asarray(p_optical, dtype=float)[None, :]
    return mask_residuals_rays(camera, p, np.array([float(radius)]), camera.rays(contour_uv), model, extra_sigma_px)[0]


def mask_residuals_rays(
    camera: Camera,
    p_optical: NDArray[np.floating],
    radii: NDArray[np.floating],
    rays_optical: NDArray[np.floating],
    model: Any,
    extra_sigma_px: float = 0.0,
) -> NDArray[np.float64]:
    """:func:`mask_residuals` for P spheres at once, from the contour's unit viewing rays.

    Parameters
    ----------
    p_optical : ndarray, shape (P, 3), metres, optical frame, sphere centres
    radii : ndarray, shape (P,), metres
    rays_optical : ndarray, shape (M, 3), unit rays of the contour points (``camera.rays(contour_uv)``;
        computed once, the refinement calls this many times)

    Returns
    -------
    residuals : ndarray, shape (P, M); ``UNDEFINED_RESIDUAL`` where the camera is inside the sphere or it is behind the camera
    """
    dist = np.linalg.norm(p_optical, axis=1)
    valid = (dist > radii) & (p_optical[:, 2] > 0)
    dist_safe = np.where(valid, dist, 1.0)
    c = p_optical / dist_safe[:, None]
    ang = np.arccos(np.clip(c @ rays_optical.T, -1.0, 1.0))
    ang_s = np.arcsin(np.where(valid, radii / dist_safe, 0.0))
    f = 0.5 * (camera.fx + camera.fy)
    sigma = model.edge_sigma_px(2 * f * np.tan(ang_s))  # the silhouette's diameter, pixels
    if extra_sigma_px:
        sigma = np.hypot(sigma, extra_sigma_px)
    out = (ang - ang_s[:, None]) * f / sigma[:, None]
    out[~valid] = UNDEFINED_RESIDUAL
    return out
