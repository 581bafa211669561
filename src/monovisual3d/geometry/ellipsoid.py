"""Ellipsoids in views: dual quadric, projected conic, image box, silhouette contour, volume.

An ellipsoid is its centre, its three semi-axes ``(a, b, c)`` and the rotation
``R_base_ellipsoid`` whose columns are its axes in the base frame (``a`` along
the first column, ``c`` along the third). Its points are
``x = centre + R diag(a, b, c) s`` for unit vectors ``s``.

The dual quadric, its projected dual conic and the closed-form box of a conic live in
:mod:`.quadric`; the "upright" rotation and quaternions in :mod:`.orientation`. This module
gives the boxes (closed form without distortion, from the rim's points with it), the silhouette
contour and the :class:`Ellipsoid` object.

All functions broadcast over leading batch dimensions; metres and radians,
pixels for image quantities (the convention of :mod:`monovisual3d.camera`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import check_quaternion_xyzw, is_int, vector
from ..errors import InputError
from .curve_box import sampled_curve_box
from .orientation import DEFAULT_UP, quaternion_xyzw_from_rotation, rotation_from_quaternion_xyzw, rotation_upright
from .quadric import bbox_from_dual_conic, centre_and_shape_matrix, dual_quadric, projected_dual_conic, to_optical
from .sphere import clip_boxes

#: Shape names, from most to least constrained.
SHAPES = ("sphere", "spheroid", "ellipsoid")
#: Rim points of a drawn outline (:func:`ellipsoid_contour_uv`).
CONTOUR_POINTS = 720
#: Rim points sampled for the box under lens distortion, each extreme refined by a parabola
#: (:func:`.curve_box.sampled_curve_box`: within 0.001 px of the rim's box for the lenses of real cameras; why:
#: docs/decisions/input-checks.md#box_contour_points).
BOX_CONTOUR_POINTS = 48


# ---------------------------------------------------------------------- size
def ellipsoid_volume(semi_axes: ArrayLike) -> NDArray[np.float64]:
    """Volume ``4/3 pi a b c`` (m^3) of ellipsoids with semi-axes (..., 3) in metres; shape (...)."""
    s = np.asarray(semi_axes, dtype=float)
    return 4.0 / 3.0 * math.pi * np.prod(s, axis=-1)


def equivalent_radius(semi_axes: ArrayLike) -> NDArray[np.float64]:
    """Radius (m) of the sphere of equal volume, ``(a b c)^(1/3)``; semi_axes (..., 3) -> (...)."""
    return np.cbrt(np.prod(np.asarray(semi_axes, dtype=float), axis=-1))


def shape_of(semi_axes: ArrayLike, rtol: float = 1e-6) -> str:
    """``"sphere"``, ``"spheroid"`` (two equal semi-axes) or ``"ellipsoid"``, equality within ``rtol``.

    Examples
    --------
    >>> shape_of([0.02, 0.02, 0.09]), shape_of([0.03, 0.03, 0.03])
    ('spheroid', 'sphere')
    """
    s = np.sort(np.asarray(semi_axes, dtype=float).reshape(3))
    eq01 = s[1] - s[0] <= rtol * s[1]
    eq12 = s[2] - s[1] <= rtol * s[2]
    if eq01 and eq12:
        return "sphere"
    return "spheroid" if eq01 or eq12 else "ellipsoid"


# ---------------------------------------------------------------------- boxes
def ellipsoid_bbox_optical(
    camera: Camera,
    centre_optical: ArrayLike,
    semi_axes: ArrayLike,
    R_optical_ellipsoid: ArrayLike,
    *,
    clip: bool = True,
    n_contour: int = BOX_CONTOUR_POINTS,
) -> NDArray[np.float64]:
    """Bounding box of the silhouette of ellipsoids given in the optical frame.

    Without lens distortion the box is exact (closed form from the projected
    dual conic). With distortion the rim is sampled (``n_contour`` points) and projected, and each extreme refined
    by a parabola (:func:`.curve_box.sampled_curve_box`).

    Parameters
    ----------
    camera : Camera
    centre_optical : array_like, shape (..., 3), metres, optical frame
    semi_axes : array_like, shape (..., 3), metres
    R_optical_ellipsoid : array_like, shape (..., 3, 3), the axes (columns) in the optical frame
    clip : bool, clip the box to the image
    n_contour : int, rim points with distortion

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels. NaN where the ellipsoid is not
        entirely in front of the camera (``z > 0`` half-space; its box is unbounded),
        or, with ``clip``, where it lies entirely outside the image.

    Examples
    --------
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> ellipsoid_bbox_optical(cam, [0.0, 0.0, 1.0], [0.1, 0.1, 0.1], np.eye(3)).round(2)
    array([269.75, 189.75, 370.25, 290.25])
    """
    c, M = centre_and_shape_matrix(centre_optical, semi_axes, R_optical_ellipsoid)
    ok = (c[..., 2] > 0) & (c[..., 2] ** 2 > M[..., 2, 2])  # min z over the ellipsoid is > 0
    if camera.distortion_model == "none":
        N = M - c[..., :, None] * c[..., None, :]
        n = bbox_from_dual_conic(N)  # normalised coordinates
        out = np.stack(
            [
                camera.fx * n[..., 0] + camera.cx,
                camera.fy * n[..., 1] + camera.cy,
                camera.fx * n[..., 2] + camera.cx,
                camera.fy * n[..., 3] + camera.cy,
            ],
            axis=-1,
        )
    else:
        uv = camera.project(ellipsoid_contour_optical(centre_optical, semi_axes, R_optical_ellipsoid, n_contour))
        out = sampled_curve_box(uv, closed=True)
    out = np.where(ok[..., None], out, np.nan)
    if clip:
        out = clip_boxes(out, camera.width, camera.height)
    return out


def ellipsoid_bbox(
    camera: Camera,
    T_base_optical: ArrayLike,
    centre_base: ArrayLike,
    semi_axes: ArrayLike,
    R_base_ellipsoid: ArrayLike,
    *,
    clip: bool = True,
    n_contour: int = BOX_CONTOUR_POINTS,
) -> NDArray[np.float64]:
    """:func:`ellipsoid_bbox_optical` for ellipsoids given in the base frame.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (..., 4, 4), pose(s) of the view(s)
    centre_base : array_like, shape (..., 3), metres, base frame
    semi_axes : array_like, shape (..., 3), metres
    R_base_ellipsoid : array_like, shape (..., 3, 3)
    clip, n_contour : see :func:`ellipsoid_bbox_optical`

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels (leading dimensions broadcast)

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> T = look_at([0, 0, 0], [1, 0, 0])
    >>> ellipsoid_bbox(cam, T, [1.0, 0, 0], [0.1, 0.1, 0.2], np.eye(3)).round(1)  # taller than wide
    array([269.7, 139.5, 370.3, 340.5])
    """
    c_opt, R_opt = to_optical(T_base_optical, centre_base, R_base_ellipsoid)
    return ellipsoid_bbox_optical(camera, c_opt, semi_axes, R_opt, clip=clip, n_contour=n_contour)


# ---------------------------------------------------------------------- contour
def ellipsoid_contour_optical(
    centre_optical: ArrayLike, semi_axes: ArrayLike, R_optical_ellipsoid: ArrayLike, n: int = CONTOUR_POINTS
) -> NDArray[np.float64]:
    """Points of the rim (contour generator) of ellipsoids seen from the optical centre.

    The rim is where the viewing rays graze the surface; it projects onto the
    silhouette's outline. In the ellipsoid's unit-sphere coordinates
    ``s = diag(1/abc) R^T (x - centre)`` it is a circle, sampled at ``n`` equal angles.

    Parameters
    ----------
    centre_optical : array_like, shape (..., 3), metres, optical frame
    semi_axes : array_like, shape (..., 3), metres
    R_optical_ellipsoid : array_like, shape (..., 3, 3)
    n : int, points per rim

    Returns
    -------
    p_optical : ndarray, shape (..., n, 3), metres, optical frame; NaN where the
        camera centre is inside the ellipsoid (no rim)
    """
    if not is_int(n) or n < 4:
        raise InputError(f"n: got {n!r}, expected an integer >= 4 (rim points)")
    c, _ = centre_and_shape_matrix(centre_optical, semi_axes, R_optical_ellipsoid)
    s = np.broadcast_to(np.asarray(semi_axes, dtype=float), c.shape)
    R = np.broadcast_to(np.asarray(R_optical_ellipsoid, dtype=float), c.shape[:-1] + (3, 3))
    A = R * s[..., None, :]  # R diag(s)
    o = -np.einsum("...ji,...j->...i", R, c) / s  # camera centre in unit-sphere coordinates
    d2 = np.sum(o * o, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = o / d2[..., None]
        rho = np.sqrt(np.where(d2 > 1, 1 - 1 / d2, np.nan))
    axis = o / np.sqrt(d2)[..., None]
    helper = np.where(np.abs(axis[..., :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(axis, e1)
    t = np.linspace(0, 2 * np.pi, int(n), endpoint=False)
    unit = m[..., None, :] + rho[..., None, None] * (
        np.cos(t)[:, None] * e1[..., None, :] + np.sin(t)[:, None] * e2[..., None, :]
    )
    return c[..., None, :] + np.einsum("...ij,...nj->...ni", A, unit)


def ellipsoid_contour_uv(
    camera: Camera,
    T_base_optical: ArrayLike,
    centre_base: ArrayLike,
    semi_axes: ArrayLike,
    R_base_ellipsoid: ArrayLike,
    n: int = CONTOUR_POINTS,
) -> NDArray[np.float64]:
    """The silhouette outline in pixels (lens distortion applied): rim points projected.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (..., 4, 4)
    centre_base : array_like, shape (..., 3), metres, base frame
    semi_axes : array_like, shape (..., 3), metres
    R_base_ellipsoid : array_like, shape (..., 3, 3)
    n : int, points on the outline

    Returns
    -------
    uv : ndarray, shape (..., n, 2), pixels; NaN where the ellipsoid is not entirely in front of the camera
    """
    c_opt, R_opt = to_optical(T_base_optical, centre_base, R_base_ellipsoid)
    c, M = centre_and_shape_matrix(c_opt, semi_axes, R_opt)
    ok = (c[..., 2] > 0) & (c[..., 2] ** 2 > M[..., 2, 2])
    uv = camera.project(ellipsoid_contour_optical(c_opt, semi_axes, R_opt, n))
    return np.where(ok[..., None, None], uv, np.nan)


def silhouette_distance_px(
    camera: Camera,
    T_base_optical: ArrayLike,
    centre_base: ArrayLike,
    semi_axes: ArrayLike,
    R_base_ellipsoid: ArrayLike,
    uv: ArrayLike,
) -> NDArray[np.float64]:
    """Signed distance (pixels) of image points to the silhouette outline: negative inside, positive outside.

    Each point ``p`` is compared with the outline point ``p_b`` on the ray from the ellipse's
    centre through ``p``; the distance is measured along the outline's normal at ``p_b``
    (the distance to the tangent line there). It is exact on the outline and to first order
    near it (where mask contour points lie), and finite everywhere (minus the smallest
    semi-axis of the ellipse at its centre). Lens distortion is removed from ``uv`` first; the
    distance is in pixels of the undistorted image.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (..., 4, 4)
    centre_base : array_like, shape (..., 3), metres, base frame
    semi_axes : array_like, shape (..., 3), metres
    R_base_ellipsoid : array_like, shape (..., 3, 3)
    uv : array_like, shape (..., M, 2), pixels, e.g. the outline of an instance mask

    Returns
    -------
    distance_px : ndarray, shape (..., M); NaN where the ellipsoid is not entirely in front of the camera

    Examples
    --------
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> uv = [[320.0, 240.0], [380.0, 240.0]]  # the outline crosses the row at 370.25
    >>> silhouette_distance_px(cam, np.eye(4), [0, 0, 1.0], [0.1, 0.1, 0.1], np.eye(3), uv).round(2)
    array([-50.25,   9.75])
    """
    c_opt, R_opt = to_optical(T_base_optical, centre_base, R_base_ellipsoid)
    c, M = centre_and_shape_matrix(c_opt, semi_axes, R_opt)
    ok = (c[..., 2] > 0) & (c[..., 2] ** 2 > M[..., 2, 2])
    K = camera.K
    C_star = K @ np.where(ok[..., None, None], M - c[..., :, None] * c[..., None, :], -np.eye(3)) @ K.T
    x0 = C_star[..., :2, 2] / C_star[..., 2:3, 2]  # the ellipse's centre, pixels
    C = np.linalg.inv(C_star)  # point conic, pixels
    A = C[..., :2, :2]
    x0h = np.concatenate([x0, np.ones(x0.shape[:-1] + (1,))], axis=-1)
    k = np.abs(np.einsum("...i,...ij,...j->...", x0h, C, x0h))[..., None]  # (p - x0)^T A (p - x0) = -f(x0) on the outline
    r = camera.undistort_pixels(uv) - x0[..., None, :]
    Ar = np.einsum("...ij,...mj->...mi", A, r)
    q = np.abs(np.sum(r * Ar, axis=-1)) / k  # 1 on the outline
    sq = np.sqrt(q)
    norm_Ar = np.linalg.norm(Ar, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = (sq - 1.0) * sq * k / norm_Ar
    minor = np.sqrt(k / np.max(np.abs(np.linalg.eigvalsh(A)), axis=-1, keepdims=True))
    d = np.where(norm_Ar > 1e-12 * np.sqrt(k), d, -minor)
    return np.where(ok[..., None], d, np.nan)


# ---------------------------------------------------------------------- the object
@dataclass(frozen=True)
class Ellipsoid:
    """An ellipsoid in the base frame.

    Attributes
    ----------
    centre_base : ndarray, shape (3,), metres, base frame
    semi_axes : ndarray, shape (3,), metres, along the axes of ``rotation``'s columns
    quaternion_xyzw : ndarray, shape (4,), orientation of the axes in the base frame (w >= 0)

    Examples
    --------
    >>> e = Ellipsoid.spheroid([0.6, 0.0, 0.45], 0.022, 0.09)
    >>> e.shape, round(e.equivalent_radius * 1e3, 1)
    ('spheroid', 35.2)
    """

    centre_base: NDArray[np.float64]
    semi_axes: NDArray[np.float64]
    quaternion_xyzw: NDArray[np.float64]

    def __post_init__(self) -> None:
        c = vector(self.centre_base, 3, "centre_base")
        s = vector(self.semi_axes, 3, "semi_axes")
        if not np.all(s > 0):
            raise InputError(f"semi_axes: got {s.tolist()}, expected three positive lengths in metres")
        q = check_quaternion_xyzw(self.quaternion_xyzw, where="quaternion_xyzw")
        object.__setattr__(self, "centre_base", c)
        object.__setattr__(self, "semi_axes", s)
        object.__setattr__(self, "quaternion_xyzw", -q if q[3] < 0 else q)

    @classmethod
    def from_rotation(cls, centre_base: ArrayLike, semi_axes: ArrayLike, R_base_ellipsoid: ArrayLike) -> Ellipsoid:
        """From a rotation matrix (3, 3) whose columns are the axes in the base frame."""
        return cls(
            np.asarray(centre_base, dtype=float),
            np.asarray(semi_axes, dtype=float),
            quaternion_xyzw_from_rotation(R_base_ellipsoid),
        )

    @classmethod
    def sphere(cls, centre_base: ArrayLike, radius: float) -> Ellipsoid:
        """A sphere (identity orientation)."""
        return cls(np.asarray(centre_base, dtype=float), np.full(3, float(radius)), np.array([0.0, 0.0, 0.0, 1.0]))

    @classmethod
    def upright(cls, centre_base: ArrayLike, semi_axes: ArrayLike, yaw: float = 0.0, up: ArrayLike = DEFAULT_UP) -> Ellipsoid:
        """Third semi-axis along ``up``, the first at ``yaw`` (radians) about it (:func:`rotation_upright`)."""
        return cls.from_rotation(centre_base, semi_axes, rotation_upright(yaw, up))

    @classmethod
    def spheroid(cls, centre_base: ArrayLike, horizontal: float, vertical: float, up: ArrayLike = DEFAULT_UP) -> Ellipsoid:
        """Upright spheroid: semi-axes ``(horizontal, horizontal, vertical)``, symmetry axis along ``up``."""
        return cls.upright(centre_base, [horizontal, horizontal, vertical], 0.0, up)

    @property
    def rotation(self) -> NDArray[np.float64]:
        """``R_base_ellipsoid``, shape (3, 3): the axes (columns) in the base frame."""
        return rotation_from_quaternion_xyzw(self.quaternion_xyzw)

    @property
    def shape(self) -> str:
        """``"sphere"``, ``"spheroid"`` or ``"ellipsoid"`` (:func:`shape_of`)."""
        return shape_of(self.semi_axes)

    @property
    def volume_m3(self) -> float:
        return float(ellipsoid_volume(self.semi_axes))

    @property
    def equivalent_radius(self) -> float:
        """Radius of the sphere of equal volume, metres."""
        return float(equivalent_radius(self.semi_axes))

    def dual_quadric(self) -> NDArray[np.float64]:
        """``Q*`` (4, 4) in the base frame (:func:`dual_quadric`)."""
        return dual_quadric(self.centre_base, self.semi_axes, self.rotation)

    def projected_dual_conic(self, camera: Camera, T_base_optical: ArrayLike) -> NDArray[np.float64]:
        """``C*`` (..., 3, 3) in pixels for view pose(s) (..., 4, 4) (:func:`projected_dual_conic`)."""
        return projected_dual_conic(camera, T_base_optical, self.centre_base, self.semi_axes, self.rotation)

    def bbox(self, camera: Camera, T_base_optical: ArrayLike, *, clip: bool = True) -> NDArray[np.float64]:
        """Box (..., 4) in pixels for view pose(s) (..., 4, 4) (:func:`ellipsoid_bbox`)."""
        return ellipsoid_bbox(camera, T_base_optical, self.centre_base, self.semi_axes, self.rotation, clip=clip)

    def contour_uv(self, camera: Camera, T_base_optical: ArrayLike, n: int = CONTOUR_POINTS) -> NDArray[np.float64]:
        """Silhouette outline (..., n, 2) in pixels (:func:`ellipsoid_contour_uv`)."""
        return ellipsoid_contour_uv(camera, T_base_optical, self.centre_base, self.semi_axes, self.rotation, n)

    def to_dict(self) -> dict[str, Any]:
        """``position``, ``radius`` (volume-equivalent), ``shape``, ``semi_axes``, ``quaternion_xyzw``, ``volume_m3``."""
        return {
            "position": [float(v) for v in self.centre_base],
            "radius": self.equivalent_radius,
            "shape": self.shape,
            "semi_axes": [float(v) for v in self.semi_axes],
            "quaternion_xyzw": [float(v) for v in self.quaternion_xyzw],
            "volume_m3": self.volume_m3,
        }
