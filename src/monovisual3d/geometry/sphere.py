"""Images of spheres: the bounding box of a sphere's silhouette in a view (the one home of this geometry).

- :func:`sphere_bbox_optical` / :func:`sphere_bbox`: the exact box (closed form without distortion, the
  sampled rim with distortion): the simulator's truth;
- :func:`predict_sphere_boxes`: the ``bayes`` likelihood's model (closed form, distortion applied to the
  four edge midpoints), every centre against every radius;
- :func:`pinhole_sphere_boxes`: the same without distortion in a few algebraic operations (the
  refinement's hot path).

The compiled kernels (``methods/bayes/_kernels.py``, ``methods/paper/engine``) are tested against these.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera, distort_normalised
from ..frames import invert_transform, transform_points


def sphere_bbox_optical(
    camera: Camera, centre_optical: ArrayLike, radius: ArrayLike, *, clip: bool = True
) -> NDArray[np.float64]:
    """Bounding box of the silhouette of spheres, given in the optical frame.

    Without lens distortion the box is exact: its vertical edges are the
    planes through the camera centre that contain the optical y axis and touch
    the sphere (likewise for the horizontal edges). With distortion the rim
    circle is sampled (720 points) and projected.

    Parameters
    ----------
    camera : Camera
    centre_optical : array_like, shape (..., 3), metres, optical frame
    radius : array_like, shape (...) or scalar, metres
    clip : bool, clip the box to the image

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels. NaN where the sphere is not
        entirely in front of the camera (its box is unbounded), or, with
        ``clip``, where it lies entirely outside the image.

    Examples
    --------
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> sphere_bbox_optical(cam, [0.0, 0.0, 1.0], 0.1).round(2)
    array([269.75, 189.75, 370.25, 290.25])
    """
    c = np.asarray(centre_optical, dtype=float)
    r = np.asarray(radius, dtype=float)
    shape = np.broadcast_shapes(c.shape[:-1], r.shape)
    c = np.broadcast_to(c, shape + (3,))
    r = np.broadcast_to(r, shape)
    X, Y, Z = c[..., 0], c[..., 1], c[..., 2]
    ok = Z > r  # the whole sphere in front of the image plane's half-space
    if camera.distortion_model == "none":
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.stack(
                [
                    *_tangent_extent(X, Z, r, camera.fx, camera.cx),
                    *_tangent_extent(Y, Z, r, camera.fy, camera.cy),
                ],
                axis=-1,
            )[..., [0, 2, 1, 3]]
    else:
        out = _rim_box(camera, c, r)
    out = np.where(ok[..., None], out, np.nan)
    if clip:
        out = clip_boxes(out, camera.width, camera.height)
    return out


def sphere_bbox(
    camera: Camera, T_base_optical: ArrayLike, centre_base: ArrayLike, radius: ArrayLike, *, clip: bool = True
) -> NDArray[np.float64]:
    """:func:`sphere_bbox_optical` for spheres given in the base frame (centre_base shape (..., 3))."""
    c_opt = transform_points(invert_transform(T_base_optical), centre_base)
    return sphere_bbox_optical(camera, c_opt, radius, clip=clip)


def clip_boxes(boxes_xyxy: NDArray[np.floating], width: int, height: int) -> NDArray[np.float64]:
    """Clip boxes (..., 4) to the image; boxes entirely outside become NaN."""
    b = np.array(boxes_xyxy, dtype=float, copy=True)
    outside = (b[..., 2] <= 0) | (b[..., 3] <= 0) | (b[..., 0] >= width) | (b[..., 1] >= height)
    b[..., 0] = np.clip(b[..., 0], 0, width)
    b[..., 2] = np.clip(b[..., 2], 0, width)
    b[..., 1] = np.clip(b[..., 1], 0, height)
    b[..., 3] = np.clip(b[..., 3], 0, height)
    b[outside] = np.nan
    return b


def _tangent_extent(A: NDArray, Z: NDArray, r: NDArray, f: float, c: float) -> tuple[NDArray, NDArray]:
    rho = np.sqrt(A * A + Z * Z)
    phi = np.arctan2(A, Z)
    half = np.arcsin(np.clip(r / rho, 0, 1))
    return f * np.tan(phi - half) + c, f * np.tan(phi + half) + c


def _rim_box(camera: Camera, c: NDArray, r: NDArray, n: int = 720) -> NDArray:
    d2 = np.sum(c * c, axis=-1)
    scale = 1 - r * r / d2
    centre = c * scale[..., None]
    rho = r * np.sqrt(np.clip(scale, 0, None))
    axis = c / np.sqrt(d2)[..., None]
    helper = np.where(np.abs(axis[..., :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(axis, e1)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = centre[..., None, :] + rho[..., None, None] * (
        np.cos(t)[:, None] * e1[..., None, :] + np.sin(t)[:, None] * e2[..., None, :]
    )
    uv = camera.project(pts)
    return np.concatenate([uv.min(axis=-2), uv.max(axis=-2)], axis=-1)


def predict_sphere_boxes(
    camera: Camera, p_optical: NDArray[np.floating], radii: NDArray[np.floating]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Predicted (unclipped) silhouette boxes of spheres: the fast model of the ``bayes`` likelihood.

    Parameters
    ----------
    camera : Camera
    p_optical : ndarray, shape (N, 3), sphere centres, metres, optical frame
    radii : ndarray, shape (K,), metres, every radius at every centre; or shape (N, K), radii per centre

    Returns
    -------
    boxes : ndarray, shape (N, K, 4), pixels ``(x1, y1, x2, y2)`` (NaN where not in front)
    visible : ndarray, shape (N, K), bool: sphere entirely in front of the camera
        and its box overlaps the image

    Notes
    -----
    Exact for an undistorted pinhole. With distortion, the undistorted box's
    four edge midpoints are distorted (a close approximation for the mild
    distortion of calibrated cameras).
    """
    X = p_optical[:, 0:1]
    Y = p_optical[:, 1:2]
    Z = p_optical[:, 2:3]
    r = np.asarray(radii, dtype=float)
    r = r[None, :] if r.ndim == 1 else r
    front = Z > r
    with np.errstate(invalid="ignore", divide="ignore"):
        rho_x = np.sqrt(X * X + Z * Z)
        rho_y = np.sqrt(Y * Y + Z * Z)
        phi_x = np.arctan2(X, Z)
        phi_y = np.arctan2(Y, Z)
        hx = np.arcsin(np.clip(r / rho_x, 0.0, 1.0))
        hy = np.arcsin(np.clip(r / rho_y, 0.0, 1.0))
        x1, x2 = np.tan(phi_x - hx), np.tan(phi_x + hx)
        y1, y2 = np.tan(phi_y - hy), np.tan(phi_y + hy)
    if camera.distortion_model != "none":
        with np.errstate(invalid="ignore", divide="ignore"):  # Z = 0: NaN, masked by ``front`` below
            xc = np.broadcast_to(X / Z, x1.shape)
            yc = np.broadcast_to(Y / Z, y1.shape)
        pts = np.stack([np.stack([x1, yc], -1), np.stack([x2, yc], -1), np.stack([xc, y1], -1), np.stack([xc, y2], -1)], axis=-2)
        d = distort_normalised(pts, camera.distortion_model, camera.distortion_coefficients)
        x1, x2, y1, y2 = d[..., 0, 0], d[..., 1, 0], d[..., 2, 1], d[..., 3, 1]
    boxes = np.stack(
        [camera.fx * x1 + camera.cx, camera.fy * y1 + camera.cy, camera.fx * x2 + camera.cx, camera.fy * y2 + camera.cy], axis=-1
    )
    boxes = np.where(front[..., None], boxes, np.nan)
    visible = front & (boxes[..., 2] > 0) & (boxes[..., 0] < camera.width) & (boxes[..., 3] > 0) & (boxes[..., 1] < camera.height)
    return boxes, visible


def pinhole_sphere_boxes(
    camera: Camera, p_optical: NDArray[np.floating], radius: NDArray[np.floating] | float
) -> NDArray[np.float64]:
    """:func:`predict_sphere_boxes` for one radius and no distortion, in a few numpy operations (the refinement's hot path).

    Same maths as the fused kernels (``methods/bayes/_kernels.py``, tested against this): ``tan(phi -/+ h) = (t -/+ s) / (1 +/- t s)`` with ``t = X / Z`` and
    ``s = tan(h) = r / sqrt(X^2 + Z^2 - r^2)``. ``p_optical`` has shape (..., 3) and ``radius`` broadcasts
    against ``p_optical[..., 0]``; returns shape (..., 4), NaN where the sphere is not entirely in front.
    """
    X, Y, Z = p_optical[..., 0], p_optical[..., 1], p_optical[..., 2]
    r = np.broadcast_to(radius, X.shape)
    r2 = r * r
    with np.errstate(invalid="ignore", divide="ignore"):
        tx, ty = X / Z, Y / Z
        sx = r / np.sqrt(X * X + Z * Z - r2)
        sy = r / np.sqrt(Y * Y + Z * Z - r2)
        out = np.stack(
            [
                camera.fx * (tx - sx) / (1 + tx * sx) + camera.cx,
                camera.fy * (ty - sy) / (1 + ty * sy) + camera.cy,
                camera.fx * (tx + sx) / (1 - tx * sx) + camera.cx,
                camera.fy * (ty + sy) / (1 - ty * sy) + camera.cy,
            ],
            axis=-1,
        )
    out[~(Z > r)] = np.nan
    return out
