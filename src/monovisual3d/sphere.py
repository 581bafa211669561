"""Images of spheres: the bounding box of a sphere's silhouette in a view."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .camera import Camera
from .frames import invert_transform, transform_points


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
