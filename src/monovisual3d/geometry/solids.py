"""Boxes of solids that are not ellipsoids: upright cylinders (cans, bottles, containers) and cuboids (boxes).

A detector's box is the bounding box of the object's silhouette. An ellipsoid model of a cylinder or a cuboid
predicts boxes that are systematically off when the camera looks from above (the top rim of a cylinder sticks out
where an ellipsoid narrows), which biases the fitted centre downwards, by a few millimetres for a 5 x 5 x 12 cm
container seen from 15-30 degrees above (docs/decisions/bayes-shapes.md#solids). These are the exact boxes.

**Cylinder** (centre ``c``, radius ``r``, half-height ``h``, axis ``u``: the third column of its rotation). It is
the convex hull of its two rim circles, so its silhouette is the convex hull of the two projected rims and its box
is the union of the rims' boxes. A circle of radius ``r`` about ``p`` in the plane normal to ``u`` is the flat
ellipsoid with semi-axes ``(r, r, 0)``: its dual quadric ``[[r^2 (I - u u^T) - p p^T, -p], [-p^T, -1]]`` needs no
inverse, and its image is the dual conic whose tangent lines give the box in closed form
(:func:`.quadric.bbox_from_dual_conic`, the formula of :func:`.ellipsoid.ellipsoid_bbox_optical`, which takes a zero
semi-axis). With lens distortion the rims are sampled (``n_contour`` points each) and projected.

**Cuboid** (centre, half-sides ``(a, b, c)`` along its rotation's columns). Its silhouette is the convex hull of its 8
projected corners (pinhole: straight edges stay straight), so its box is theirs. With distortion the 12 edges are
sampled.

Metres and radians; boxes in pixels ``(x1, y1, x2, y2)``, unclipped unless ``clip``; NaN where the solid is not
entirely in front of the camera. Every function broadcasts over leading batch dimensions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import is_int
from ..errors import InputError
from .curve_box import sampled_curve_box
from .ellipsoid import ellipsoid_bbox_optical
from .quadric import to_optical
from .sphere import clip_boxes

#: Solid models (the fit's names; an object reports the ellipsoid with the same semi-axes as its shape).
SOLIDS = ("cylinder", "cuboid")
#: Points sampled per rim circle under lens distortion, and per cuboid edge, each extreme refined by a parabola
#: (:func:`.curve_box.sampled_curve_box`: within 0.001 px of the outline's box for the lenses of real cameras).
SOLID_CONTOUR_POINTS = 48
EDGE_POINTS = 8
#: The cuboid's corners in units of its half-sides, shape (8, 3).
CUBE_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
#: The cuboid's 12 edges as pairs of indices into :data:`CUBE_CORNERS` (corners differing in one sign).
CUBE_EDGES = np.array([(i, j) for i in range(8) for j in range(i + 1, 8) if np.sum(CUBE_CORNERS[i] != CUBE_CORNERS[j]) == 1])


def union_boxes(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """The box (..., 4) enclosing the boxes ``a`` and ``b`` (..., 4); NaN where either is NaN."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.concatenate([np.minimum(a[..., :2], b[..., :2]), np.maximum(a[..., 2:], b[..., 2:])], axis=-1)


def _check_n(n_contour: int) -> None:
    if not is_int(n_contour) or n_contour < 4:
        raise InputError(f"n_contour: got {n_contour!r}, expected an integer >= 4 (sampled points)")


def circle_bbox_optical(
    camera: Camera,
    centre_optical: ArrayLike,
    radius: ArrayLike,
    R_optical_circle: ArrayLike,
    *,
    n_contour: int = SOLID_CONTOUR_POINTS,
) -> NDArray[np.float64]:
    """Box of circles given in the optical frame.

    Parameters
    ----------
    camera : Camera
    centre_optical : array_like, shape (..., 3), metres, optical frame
    radius : array_like, shape (...), metres (> 0)
    R_optical_circle : array_like, shape (..., 3, 3), rotation whose third column is the circle's normal
    n_contour : int, points sampled on the circle under lens distortion

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels, unclipped; NaN where the circle is not entirely in front

    Examples
    --------
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> circle_bbox_optical(cam, [0.0, 0.0, 1.0], 0.1, np.eye(3)).round(2)  # facing the camera: a circle of 50 px
    array([270., 190., 370., 290.])
    """
    _check_n(n_contour)
    r = np.asarray(radius, dtype=float)
    if np.any(~(r > 0)):
        raise InputError(f"radius: got {r.ravel()[:4].tolist()}, expected positive lengths in metres")
    semi = np.stack([r, r, np.zeros_like(r)], axis=-1)
    if camera.distortion_model == "none":
        return ellipsoid_bbox_optical(camera, centre_optical, semi, R_optical_circle, clip=False)
    t = np.linspace(0.0, 2.0 * np.pi, n_contour, endpoint=False)
    R = np.asarray(R_optical_circle, dtype=float)
    c = np.asarray(centre_optical, dtype=float)
    p = c[..., None, :] + r[..., None, None] * (np.cos(t)[:, None] * R[..., None, :, 0] + np.sin(t)[:, None] * R[..., None, :, 1])
    uv = camera.project(p)  # (..., n, 2), NaN behind the camera
    return sampled_curve_box(uv, closed=True)


def cylinder_bbox(
    camera: Camera,
    T_base_optical: ArrayLike,
    centre_base: ArrayLike,
    radius: ArrayLike,
    half_height: ArrayLike,
    R_base_cylinder: ArrayLike,
    *,
    clip: bool = False,
    n_contour: int = SOLID_CONTOUR_POINTS,
) -> NDArray[np.float64]:
    """Boxes of cylinders: the union of the boxes of their two rim circles.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (..., 4, 4), pose(s) of the view(s)
    centre_base : array_like, shape (..., 3), metres, base frame, the centre (halfway between the rims)
    radius, half_height : array_like, shape (...), metres (> 0)
    R_base_cylinder : array_like, shape (..., 3, 3), third column the axis (upright: :func:`.orientation.rotation_upright`)
    clip : bool, clip the box to the image
    n_contour : int, points per rim under lens distortion

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels (leading dimensions broadcast)

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> T = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])  # level, looking along base x
    >>> cylinder_bbox(cam, T, [1.0, 0.0, 0.0], 0.05, 0.1, np.eye(3)).round(1)  # the near rim points set the sides
    array([295. , 187.4, 345. , 292.6])
    """
    h = np.asarray(half_height, dtype=float)
    if np.any(~(h > 0)):
        raise InputError(f"half_height: got {h.ravel()[:4].tolist()}, expected positive lengths in metres")
    R = np.asarray(R_base_cylinder, dtype=float)
    c = np.asarray(centre_base, dtype=float)
    rims = []
    for sign in (-1.0, 1.0):
        c_opt, R_opt = to_optical(T_base_optical, c + sign * h[..., None] * R[..., :, 2], R)
        rims.append(circle_bbox_optical(camera, c_opt, radius, R_opt, n_contour=n_contour))
    out = union_boxes(*rims)
    return clip_boxes(out, camera.width, camera.height) if clip else out


def cuboid_bbox(
    camera: Camera,
    T_base_optical: ArrayLike,
    centre_base: ArrayLike,
    half_sides: ArrayLike,
    R_base_cuboid: ArrayLike,
    *,
    clip: bool = False,
    n_contour: int = EDGE_POINTS,
) -> NDArray[np.float64]:
    """Boxes of cuboids: the box of the 8 projected corners (of the 12 sampled edges under lens distortion).

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (..., 4, 4), pose(s) of the view(s)
    centre_base : array_like, shape (..., 3), metres, base frame
    half_sides : array_like, shape (..., 3), metres (> 0), along the columns of ``R_base_cuboid``
    R_base_cuboid : array_like, shape (..., 3, 3)
    clip : bool, clip the box to the image
    n_contour : int, points per edge under lens distortion

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels (leading dimensions broadcast); NaN where a corner is behind the camera

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> T = look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    >>> cuboid_bbox(cam, T, [1.0, 0.0, 0.0], [0.05, 0.05, 0.1], np.eye(3)).round(1)  # the near face sets the box
    array([293.7, 187.4, 346.3, 292.6])
    """
    _check_n(n_contour)
    s = np.asarray(half_sides, dtype=float)
    if s.shape[-1:] != (3,) or np.any(~(s > 0)):
        raise InputError(f"half_sides: got shape {s.shape}, expected (..., 3) positive lengths in metres")
    R = np.asarray(R_base_cuboid, dtype=float)
    corners = CUBE_CORNERS @ np.swapaxes(R * s[..., None, :], -1, -2)  # (..., 8, 3), offsets in base
    distorted = camera.distortion_model != "none"
    if distorted:  # the 12 edges, each sampled at n_contour points: (..., 12 n, 3), edge by edge
        t = np.linspace(0.0, 1.0, n_contour)[:, None]
        a, b = corners[..., CUBE_EDGES[:, 0], :], corners[..., CUBE_EDGES[:, 1], :]  # (..., 12, 3)
        corners = ((1.0 - t) * a[..., :, None, :] + t * b[..., :, None, :]).reshape(a.shape[:-2] + (-1, 3))
    T = np.asarray(T_base_optical, dtype=float)
    c_base = np.asarray(centre_base, dtype=float)[..., None, :] + corners
    p_opt = (c_base - T[..., None, :3, 3]) @ T[..., :3, :3]  # R^T (p - t), row by row
    uv = camera.project(p_opt)
    if distorted:  # each edge a gently curved arc: its box refined, the cuboid's box their union
        edges = sampled_curve_box(uv.reshape(uv.shape[:-2] + (len(CUBE_EDGES), n_contour, 2)), closed=False)
        out = np.concatenate([edges[..., :2].min(axis=-2), edges[..., 2:].max(axis=-2)], axis=-1)
    else:
        out = np.concatenate([uv.min(axis=-2), uv.max(axis=-2)], axis=-1)
    out = np.where(np.all(p_opt[..., 2] > 0, axis=-1)[..., None], out, np.nan)
    return clip_boxes(out, camera.width, camera.height) if clip else out
