"""Boxes of upright spheroids: the ``bayes`` search's model of elongated objects.

An upright spheroid has its symmetry axis along a fixed direction ``u`` (the
base frame's vertical, ``BayesConfig.up``), a semi-axis ``b`` along it and
``a`` across it. Its dual quadric, centred at ``c`` (optical frame), is
``Q* = [[A - c c^T, -c], [-c^T, -1]]`` with ``A = a^2 I + (b^2 - a^2) u u^T``,
and its image in normalised coordinates is the dual conic
``C* = c c^T - A`` (``P = [I | 0]``, sign flipped so ``C*33 > 0`` in front).
The lines tangent to the silhouette give the box in closed form:

``x = (C*13 -/+ sqrt(C*13^2 - C*11 C*33)) / C*33``, likewise ``y`` with ``C*23, C*22``.

Exact for an undistorted pinhole; with distortion each edge is distorted at
the centre's other normalised coordinate (as :func:`.sphere.predict_sphere_boxes`).
For ``a == b`` the sphere's formula is used, so spheres give exactly the
sphere model's boxes. The compiled twin is ``_spheroid_box_px`` in
``methods/bayes/_kernels.py`` (tested against this).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera, distort_normalised
from .sphere import predict_sphere_boxes


def predict_spheroid_boxes(
    camera: Camera, p_optical: NDArray[np.floating], radii: ArrayLike, semi_up: ArrayLike, up_optical: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Predicted (unclipped) boxes of upright spheroids, every centre against every (radius, semi_up) bin.

    Parameters
    ----------
    camera : Camera
    p_optical : ndarray, shape (N, 3), centres, metres, optical frame
    radii : array_like, shape (K,), metres, semi-axis across ``up``; or shape (N, K), bins per centre
    semi_up : array_like, shape (K,) or (N, K), metres, semi-axis along ``up``
    up_optical : array_like, shape (3,), (K, 3) or (N, K, 3), unit, the symmetry axis in the optical frame (one per
        bin: lying bins have a horizontal axis; or one per centre and bin)

    Returns
    -------
    boxes : ndarray, shape (N, K, 4), pixels ``(x1, y1, x2, y2)`` (NaN where not entirely in front)
    visible : ndarray, shape (N, K), bool: in front and overlapping the image
    """
    a, b = (np.asarray(x, dtype=float) for x in (radii, semi_up))
    a, b = (x[None, :] if x.ndim == 1 else x for x in (a, b))  # (1 or N, K)
    up = np.asarray(up_optical, dtype=float)
    u = np.moveaxis(up, -1, 0) if up.ndim == 3 else up.reshape(-1, 3).T[:, None, :]  # (3, N, K) or (3, 1, 1 or K)
    X, Y, Z = p_optical[:, 0:1], p_optical[:, 1:2], p_optical[:, 2:3]
    a2, d = a * a, b * b - a * a
    c11 = X * X - (a2 + d * u[0] * u[0])
    c22 = Y * Y - (a2 + d * u[1] * u[1])
    c33 = Z * Z - (a2 + d * u[2] * u[2])
    c13 = X * Z - d * u[0] * u[2]
    c23 = Y * Z - d * u[1] * u[2]
    front = (Z > 0) & (c33 > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        sx = np.sqrt(np.maximum(c13 * c13 - c11 * c33, 0.0))
        sy = np.sqrt(np.maximum(c23 * c23 - c22 * c33, 0.0))
        x1, x2 = (c13 - sx) / c33, (c13 + sx) / c33
        y1, y2 = (c23 - sy) / c33, (c23 + sy) / c33
        if camera.distortion_model != "none":
            xc = np.broadcast_to(X / Z, x1.shape)
            yc = np.broadcast_to(Y / Z, y1.shape)
            pts = np.stack(
                [np.stack([x1, yc], -1), np.stack([x2, yc], -1), np.stack([xc, y1], -1), np.stack([xc, y2], -1)], axis=-2
            )
            dist = distort_normalised(pts, camera.distortion_model, camera.distortion_coefficients)
            x1, x2, y1, y2 = dist[..., 0, 0], dist[..., 1, 0], dist[..., 2, 1], dist[..., 3, 1]
    boxes = np.stack(
        [camera.fx * x1 + camera.cx, camera.fy * y1 + camera.cy, camera.fx * x2 + camera.cx, camera.fy * y2 + camera.cy], axis=-1
    )
    boxes = np.where(front[..., None], boxes, np.nan)
    sphere = np.broadcast_to(d == 0, front.shape)
    if sphere.any():
        sphere_boxes, _ = predict_sphere_boxes(camera, np.asarray(p_optical, dtype=float), np.broadcast_to(a, front.shape))
        boxes = np.where(sphere[..., None], sphere_boxes, boxes)
        front = np.where(sphere, Z > a, front)
    visible = front & (boxes[..., 2] > 0) & (boxes[..., 0] < camera.width) & (boxes[..., 3] > 0) & (boxes[..., 1] < camera.height)
    return boxes, visible
