"""Ellipsoids as dual quadrics, their projected dual conics, and the box of a conic in closed form.

Under a pinhole camera ``P = K [R_optical_base | t_optical_base]`` the dual quadric
``Q* = T diag(a^2, b^2, c^2, -1) T^T`` (``T`` the 4x4 transform ``[[R, centre], [0, 1]]``) projects to
the dual conic ``C* = P Q* P^T``: the image lines ``l`` tangent to the silhouette are those with
``l^T C* l = 0``. The vertical tangent lines ``u = x`` (``l = (1, 0, -x)``) solve
``C*_11 - 2 x C*_13 + x^2 C*_33 = 0``, which gives the box in closed form (:func:`bbox_from_dual_conic`).
:func:`ellipsoid_from_dual_quadric` goes back from a dual quadric (of any scale, e.g. one solved for, or
read from a file) to the ellipsoid's centre, semi-axes and axes. All functions but that one broadcast over
leading batch dimensions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError


def dual_quadric(centre: ArrayLike, semi_axes: ArrayLike, R_frame_ellipsoid: ArrayLike) -> NDArray[np.float64]:
    """Dual quadric ``Q* = T diag(a^2, b^2, c^2, -1) T^T`` of ellipsoids, in the frame of ``centre``.

    Parameters
    ----------
    centre : array_like, shape (..., 3), metres
    semi_axes : array_like, shape (..., 3), metres
    R_frame_ellipsoid : array_like, shape (..., 3, 3), the axes (columns) in the same frame

    Returns
    -------
    Q_star : ndarray, shape (..., 4, 4); planes ``pi`` tangent to the ellipsoid satisfy ``pi^T Q* pi = 0``

    Examples
    --------
    >>> Q = dual_quadric([0, 0, 1.0], [0.1, 0.1, 0.1], np.eye(3))
    >>> plane = np.array([0, 0, 1.0, -0.9])  # z = 0.9 touches the sphere
    >>> round(float(plane @ Q @ plane), 12)
    0.0
    """
    c, M = centre_and_shape_matrix(centre, semi_axes, R_frame_ellipsoid)
    out = np.empty(c.shape[:-1] + (4, 4))
    out[..., :3, :3] = M - c[..., :, None] * c[..., None, :]
    out[..., :3, 3] = -c
    out[..., 3, :3] = -c
    out[..., 3, 3] = -1.0
    return out


def ellipsoid_from_dual_quadric(Q_star: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Centre, semi-axes and axes of the ellipsoid of a dual quadric (any non-zero scale).

    With ``Q*`` scaled so that ``Q*[3, 3] = -1``: ``centre = -Q*[:3, 3]`` and
    ``Q*[:3, :3] + centre centre^T = R diag(a^2, b^2, c^2) R^T`` (the inverse of :func:`dual_quadric`).

    Parameters
    ----------
    Q_star : array_like, shape (4, 4)

    Returns
    -------
    centre : ndarray, shape (3,), in the frame of ``Q*``
    semi_axes : ndarray, shape (3,), ascending
    R : ndarray, shape (3, 3), a rotation (det +1) whose columns are the axes

    Raises
    ------
    InputError
        When ``Q*`` is not finite and symmetric, ``Q*[3, 3]`` is 0 (centre at infinity), or the
        matrix is not an ellipsoid (a non-positive ``a^2``).

    Examples
    --------
    >>> c, s, R = ellipsoid_from_dual_quadric(3.0 * dual_quadric([1.0, 2.0, 3.0], [0.1, 0.2, 0.3], np.eye(3)))
    >>> c.round(6).tolist(), s.round(6).tolist()
    ([1.0, 2.0, 3.0], [0.1, 0.2, 0.3])
    """
    Q = np.asarray(Q_star, dtype=float)
    if Q.shape != (4, 4) or not np.all(np.isfinite(Q)):
        raise InputError(f"dual quadric: expected a finite 4 x 4 matrix, got shape {Q.shape}")
    scale = float(np.max(np.abs(Q)))
    if scale == 0 or not np.allclose(Q, Q.T, rtol=0, atol=1e-9 * scale):
        raise InputError("dual quadric: expected a symmetric, non-zero 4 x 4 matrix")
    if not abs(Q[3, 3]) > 1e-12 * scale:
        raise InputError("dual quadric: Q*[3, 3] is 0, the centre lies at infinity (not an ellipsoid)")
    Q = Q / -Q[3, 3]
    centre = -Q[:3, 3]
    shape = Q[:3, :3] + np.outer(centre, centre)
    lam, R = np.linalg.eigh(0.5 * (shape + shape.T))
    if not lam[0] > 0:
        raise InputError(f"dual quadric: squared semi-axes {np.round(lam, 9).tolist()}, expected all positive (not an ellipsoid)")
    if np.linalg.det(R) < 0:
        R[:, 0] = -R[:, 0]
    return centre, np.sqrt(lam), R


def projected_dual_conic(
    camera: Camera, T_base_optical: ArrayLike, centre_base: ArrayLike, semi_axes: ArrayLike, R_base_ellipsoid: ArrayLike
) -> NDArray[np.float64]:
    """Dual conic ``C* = P Q* P^T`` (pixels) of ellipsoids under the pinhole part of ``camera``.

    Lens distortion is ignored (use :func:`~monovisual3d.geometry.ellipsoid.ellipsoid_contour_uv` for distorted cameras).

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (..., 4, 4), the view's pose
    centre_base : array_like, shape (..., 3), metres, base frame
    semi_axes : array_like, shape (..., 3), metres
    R_base_ellipsoid : array_like, shape (..., 3, 3)

    Returns
    -------
    C_star : ndarray, shape (..., 3, 3), homogeneous pixel coordinates: image lines ``l``
        tangent to the silhouette satisfy ``l^T C* l = 0``
    """
    c_opt, R_opt = to_optical(T_base_optical, centre_base, R_base_ellipsoid)
    N = normalised_dual_conic(c_opt, semi_axes, R_opt)
    K = camera.K
    return K @ N @ K.T


def bbox_from_dual_conic(C_star: ArrayLike) -> NDArray[np.float64]:
    """Box ``(x1, y1, x2, y2)`` of the ellipses with dual conics (..., 3, 3) (any scale).

    Returns NaN where the conic is not a bounded ellipse seen from the front
    (``C*_33 >= 0``, which is the case when the ellipsoid is not entirely in front of the camera).

    Examples
    --------
    >>> C = np.diag([4.0, 1.0, -1.0])  # the ellipse x^2 / 4 + y^2 = 1
    >>> bbox_from_dual_conic(C)
    array([-2., -1.,  2.,  1.])
    """
    C = np.asarray(C_star, dtype=float)
    C = C / np.where(C[..., 2, 2] < 0, -C[..., 2, 2], np.nan)[..., None, None]  # C33 = -1
    with np.errstate(invalid="ignore"):
        hx = np.sqrt(C[..., 0, 2] ** 2 + C[..., 0, 0])
        hy = np.sqrt(C[..., 1, 2] ** 2 + C[..., 1, 1])
    x0, y0 = -C[..., 0, 2], -C[..., 1, 2]
    return np.stack([x0 - hx, y0 - hy, x0 + hx, y0 + hy], axis=-1)


def centre_and_shape_matrix(
    centre: ArrayLike, semi_axes: ArrayLike, R: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Broadcast centres (..., 3) and ``M = R diag(s^2) R^T`` (..., 3, 3)."""
    c = np.asarray(centre, dtype=float)
    s = np.asarray(semi_axes, dtype=float)
    R = np.asarray(R, dtype=float)
    if c.shape[-1:] != (3,) or s.shape[-1:] != (3,) or R.shape[-2:] != (3, 3):
        raise InputError(
            f"ellipsoid: expected centre (..., 3), semi_axes (..., 3), rotation (..., 3, 3); got {c.shape}, {s.shape}, {R.shape}"
        )
    shape = np.broadcast_shapes(c.shape[:-1], s.shape[:-1], R.shape[:-2])
    c = np.broadcast_to(c, shape + (3,))
    M = np.einsum("...ik,...k,...jk->...ij", R, s * s, R)
    return c, np.broadcast_to(M, shape + (3, 3))


def normalised_dual_conic(c_opt: ArrayLike, semi_axes: ArrayLike, R_opt: ArrayLike) -> NDArray[np.float64]:
    """The dual conic in normalised image coordinates ``M - c c^T`` (..., 3, 3), of ellipsoids in the optical frame."""
    c, M = centre_and_shape_matrix(c_opt, semi_axes, R_opt)
    return M - c[..., :, None] * c[..., None, :]


def to_optical(
    T_base_optical: ArrayLike, centre_base: ArrayLike, R_base_ellipsoid: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Centres (..., 3) and rotations (..., 3, 3) in the optical frame of pose(s) (..., 4, 4)."""
    T = np.asarray(T_base_optical, dtype=float)
    if T.shape[-2:] != (4, 4):
        raise InputError(f"T_base_optical: expected shape (..., 4, 4), got {T.shape}")
    R_bo, t_bo = T[..., :3, :3], T[..., :3, 3]
    c = np.asarray(centre_base, dtype=float)
    c_opt = np.einsum("...ji,...j->...i", R_bo, c - t_bo)
    R_opt = np.einsum("...ji,...jk->...ik", R_bo, np.asarray(R_base_ellipsoid, dtype=float))
    return c_opt, R_opt
