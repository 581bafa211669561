"""What a view tells about a sphere: predicted boxes, their Jacobians, Fisher information, occlusion.

The pieces of the planner's information model (see :mod:`monovisual3d.active.planner`): the
Fisher information ``J^T W J`` of a sphere's four predicted box edges under the ``bayes`` sensor
model (:mod:`monovisual3d.methods.bayes.sensor`), the edges cut by the image border, the part of
each predicted disc nearer discs cover, and the 95 % error ellipsoid an information matrix gives.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..geometry.sphere import predict_sphere_boxes as predict_boxes

#: Confidence of the error ellipsoids (the stopping rule's 95 %).
CONFIDENCE = 0.95
#: chi-square quantile, 3 degrees of freedom, 95 %: the 95 % ellipsoid's semi-axes are sqrt(CHI2_3_95 * eigenvalues).
CHI2_3_95 = 7.814727903251178
#: Finite-difference step of the box Jacobian, metres (0.01 mm: far below a fruit's size, far above rounding).
JACOBIAN_STEP_M = 1e-5
#: Radii (unit disc) of the sample points of a predicted disc: near its rim for the edges, halfway for the interior.
_EDGE_POINT_RADIUS, _INTERIOR_POINT_RADIUS = 0.85, 0.5
#: Sample points of a predicted disc (unit disc coordinates): 3 per edge (left, top, right, bottom), then interior.
_EDGE_ANGLES = np.radians([180.0, 160.0, 200.0, 270.0, 250.0, 290.0, 0.0, 20.0, -20.0, 90.0, 70.0, 110.0])
_POINTS_PER_EDGE = 3
_EDGE_OF_POINT = np.repeat(np.arange(4), _POINTS_PER_EDGE)  # image y is down: angle 270 deg (v = -1) is the top edge
_INTERIOR_ANGLES = np.radians(np.arange(0, 360, 60))
_DISC_POINTS = np.concatenate(
    [
        _EDGE_POINT_RADIUS * np.stack([np.cos(_EDGE_ANGLES), np.sin(_EDGE_ANGLES)], -1),
        _INTERIOR_POINT_RADIUS * np.stack([np.cos(_INTERIOR_ANGLES), np.sin(_INTERIOR_ANGLES)], -1),
        np.zeros((1, 2)),
    ]
)
#: Points nearer than this to the camera plane (metres, optical z) count as not seen (inside the lens housing).
MIN_SEEN_DEPTH_M = 0.05


def boxes_and_jacobians(
    camera: Camera, T_optical_base: NDArray[np.floating], centres: NDArray[np.floating], radii: NDArray[np.floating]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """Predicted boxes of spheres in several views and their Jacobians w.r.t. ``(centre, radius)``.

    Parameters
    ----------
    camera : Camera
    T_optical_base : ndarray, shape (V, 4, 4)
    centres : ndarray, shape (M, 3), metres, base frame
    radii : ndarray, shape (M,), metres

    Returns
    -------
    boxes : ndarray, shape (V, M, 4), pixels (x1, y1, x2, y2), NaN where not in front
    J : ndarray, shape (V, M, 4, 4), d edges / d (x, y, z, r), pixels per metre, base frame
    visible : ndarray, shape (V, M), bool, in front and overlapping the image
    depth : ndarray, shape (V, M), metres, optical z of the centre
    """
    R = T_optical_base[:, :3, :3]
    t = T_optical_base[:, :3, 3]
    p = np.einsum("vij,mj->vmi", R, centres) + t[:, None, :]  # (V, M, 3)
    V, M = p.shape[:2]
    r = np.broadcast_to(radii, (V, M))
    steps = np.zeros((9, 4))
    steps[1:7, :3] = np.repeat(np.eye(3), 2, axis=0) * np.tile([JACOBIAN_STEP_M, -JACOBIAN_STEP_M], 3)[:, None]
    steps[7:, 3] = [JACOBIAN_STEP_M, -JACOBIAN_STEP_M]
    P = p[None] + steps[:, None, None, :3]  # (9, V, M, 3)
    Rr = r[None] + steps[:, None, None, 3]
    b, vis = predict_boxes(camera, P.reshape(-1, 3), Rr.reshape(-1, 1))
    b = b.reshape(9, V, M, 4)
    d_opt = np.stack([(b[1 + 2 * k] - b[2 + 2 * k]) / (2 * JACOBIAN_STEP_M) for k in range(3)], axis=-1)  # (V, M, 4, 3)
    d_r = (b[7] - b[8]) / (2 * JACOBIAN_STEP_M)  # (V, M, 4)
    J = np.concatenate([np.einsum("vmek,vkj->vmej", d_opt, R), d_r[..., None]], axis=-1)
    return b[0], J, vis.reshape(9, V, M)[0], p[..., 2]


def fisher(J: NDArray[np.floating], sigma: NDArray[np.floating], weight: NDArray[np.floating]) -> NDArray[np.float64]:
    """``J^T diag(weight / sigma^2) J`` over the last two axes: J (..., 4, 4), sigma and weight (..., 4)."""
    w = np.nan_to_num(weight / sigma**2)
    Jn = np.nan_to_num(J)
    return np.einsum("...ei,...e,...ej->...ij", Jn, w, Jn)


def border_weights(boxes: NDArray[np.floating], camera: Camera, border_px: float) -> NDArray[np.float64]:
    """1 for an edge inside the image, 0 for an edge cut by (or within ``border_px`` of) the border, shape (..., 4)."""
    x1, y1, x2, y2 = (boxes[..., k] for k in range(4))
    ok = np.stack([x1 > border_px, y1 > border_px, x2 < camera.width - border_px, y2 < camera.height - border_px], axis=-1)
    return ok.astype(float)


def occlusion_by_known(
    boxes: NDArray[np.floating], depth: NDArray[np.floating]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Visibility of each predicted disc behind the nearer ones, per edge and overall.

    Parameters
    ----------
    boxes : ndarray, shape (..., M, 4), predicted boxes (one view per leading index)
    depth : ndarray, shape (..., M), optical depth of the centres, metres

    Returns
    -------
    edge_visible : ndarray, shape (..., M, 4), fraction of each edge's sample points not covered by a nearer disc
    visible : ndarray, shape (..., M), fraction of all sample points not covered
    """
    centre = 0.5 * (boxes[..., :2] + boxes[..., 2:])  # (..., M, 2)
    half = 0.25 * ((boxes[..., 2] - boxes[..., 0]) + (boxes[..., 3] - boxes[..., 1]))  # (..., M)
    pts = centre[..., :, None, :] + half[..., :, None, None] * _DISC_POINTS  # (..., M, P, 2)
    # covered[..., i, p] = any j nearer than i whose disc contains point p of i
    d = pts[..., :, None, :, :] - centre[..., None, :, None, :]  # (..., Mi, Mj, P, 2)
    inside = (d**2).sum(-1) < (half[..., None, :, None] ** 2)
    nearer = depth[..., None, :] < depth[..., :, None]  # (..., Mi, Mj)
    covered = (inside & nearer[..., None]).any(axis=-2)  # (..., Mi, P)
    covered = np.where(np.isnan(centre[..., :1]), True, covered)
    free = ~covered
    n_edge = 4 * _POINTS_PER_EDGE
    edge_visible = free[..., :n_edge].reshape(free.shape[:-1] + (4, _POINTS_PER_EDGE)).mean(-1)
    return edge_visible, free.mean(-1)


def rms_mm(info: NDArray[np.floating]) -> NDArray[np.float64]:
    """RMS position error (mm) from information matrices (..., 4, 4)."""
    cov = np.linalg.inv(info)
    return 1e3 * np.sqrt(np.clip(np.trace(cov[..., :3, :3], axis1=-2, axis2=-1), 0.0, None))


def ellipsoid95_mm(covariance: ArrayLike) -> float:
    """Largest semi-axis of the 95 % error ellipsoid of a (3, 3) position covariance (m^2), millimetres.

    Examples
    --------
    >>> round(ellipsoid95_mm(np.eye(3) * 1e-6), 3)  # 1 mm std per axis
    2.795
    """
    S = np.asarray(covariance, dtype=float)
    return float(1e3 * math.sqrt(CHI2_3_95 * max(float(np.linalg.eigvalsh(S)[-1]), 0.0)))


def sees(camera: Camera, T_optical_base: NDArray[np.float64], p_base: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each camera sees each point: in front (beyond :data:`MIN_SEEN_DEPTH_M`) and projected inside its image.

    Parameters
    ----------
    camera : Camera, projection with its lens distortion
    T_optical_base : ndarray, shape (N, 4, 4), one per camera pose
    p_base : ndarray, shape (P, 3), metres, base frame

    Returns
    -------
    seen : ndarray, shape (N, P), bool
    """
    p = np.einsum("nij,pj->npi", T_optical_base[:, :3, :3], p_base) + T_optical_base[:, None, :3, 3]
    uv = camera.project(p)
    with np.errstate(invalid="ignore"):
        return (p[..., 2] > MIN_SEEN_DEPTH_M) & camera.in_image(uv)
