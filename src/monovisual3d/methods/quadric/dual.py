"""The dual-quadric solve of the ``quadric`` method (Rubino, Crocco, Del Bue, TPAMI 2017: "LfD").

An ellipsoid is its dual quadric ``Q*`` (4 x 4, symmetric, defined up to scale); under a camera
``P = K [R | t]`` (3 x 4, pixels) it projects to the dual conic ``C* ~ P Q* P^T`` of its outline.
LfD replaces each detection box by the axis-aligned ellipse inscribed in it (centred in the box,
semi-axes half the box sides), whose dual conic is known, and solves for ``Q*``:

- the 10 distinct entries of ``Q*`` (``v = vech(Q*)``) and one unknown scale ``beta_i`` per view enter
  linearly: ``G_i v - beta_i vech(C*_i) = 0``, six equations per view, where ``G_i`` (6 x 10) is the
  linear map ``Q* -> vech(P_i Q* P_i^T)`` (:func:`conic_map`);
- stacked over ``n >= 3`` views, the homogeneous system ``M w = 0`` (``6 n`` x ``10 + n``) is solved in
  the least-squares sense by the right singular vector of the smallest singular value of ``M``;
- preconditioning: each view's image coordinates are moved and scaled so that the image becomes
  roughly the square [-1, 1]^2, and the 3D frame so that the camera centres are centred at the origin
  at mean distance 1 (:func:`image_normalisation`, :func:`space_normalisation`); without it the entries
  of ``M`` span many orders of magnitude (pixels squared against ones) and the result depends on where
  the base frame's origin is. (Normalising each box to a unit circle and the object to a unit sphere
  instead makes the cameras near-affine in the normalised frame; with three views a degenerate quadric
  with ``Q*[3, 3]`` near 0 then often fits better than the object, so it is not done.)

The inscribed ellipse equals the projected outline only when that outline is axis-aligned in the image;
otherwise it shares the outline's bounding box (its four tangent lines) but not its shape, which biases
the estimate (LfD's modelling error, kept here: this is the published method).

``vech`` of a symmetric matrix lists its entries ``(i, j)`` with ``i <= j`` row by row
(:data:`VECH3`, :data:`VECH4`). The ellipsoid of the solved ``Q*`` is geometry, not the method:
:func:`monovisual3d.geometry.quadric.ellipsoid_from_dual_quadric`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...camera import Camera
from ...errors import InputError

#: Index pairs ``(i, j)``, ``i <= j``, of the 6 distinct entries of a symmetric 3 x 3 matrix.
VECH3 = tuple((i, j) for i in range(3) for j in range(i, 3))
#: Index pairs ``(i, j)``, ``i <= j``, of the 10 distinct entries of a symmetric 4 x 4 matrix.
VECH4 = tuple((i, j) for i in range(4) for j in range(i, 4))
#: Fewest views that fix a dual quadric (two views leave a one-parameter family, LfD Sec. 3).
MIN_VIEWS = 3


def vech(A: ArrayLike) -> NDArray[np.float64]:
    """Distinct entries ``(i <= j)`` of symmetric matrices (..., k, k), k in (3, 4): shape (..., 6) or (..., 10)."""
    A = np.asarray(A, dtype=float)
    pairs = VECH3 if A.shape[-1] == 3 else VECH4
    return np.stack([A[..., i, j] for i, j in pairs], axis=-1)


def unvech4(v: ArrayLike) -> NDArray[np.float64]:
    """The symmetric 4 x 4 matrix (..., 4, 4) of its 10 distinct entries (..., 10)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (4, 4))
    for k, (i, j) in enumerate(VECH4):
        out[..., i, j] = v[..., k]
        out[..., j, i] = v[..., k]
    return out


def inscribed_dual_conic(bbox_xyxy: ArrayLike) -> NDArray[np.float64]:
    """Dual conics (..., 3, 3) of the axis-aligned ellipses inscribed in boxes (..., 4), pixels.

    The ellipse has the box centre ``(x0, y0)`` and semi-axes ``(w/2, h/2)``; its dual conic is
    ``T diag(a^2, b^2, -1) T^T`` with ``T`` the translation to ``(x0, y0)`` (so ``C*[2, 2] = -1``).

    Examples
    --------
    >>> inscribed_dual_conic([8.0, 4.0, 12.0, 6.0])  # centre (10, 5), semi-axes (2, 1)
    array([[-96., -50., -10.],
           [-50., -24.,  -5.],
           [-10.,  -5.,  -1.]])
    """
    b = np.asarray(bbox_xyxy, dtype=float)
    x0, y0 = 0.5 * (b[..., 0] + b[..., 2]), 0.5 * (b[..., 1] + b[..., 3])
    a, c = 0.5 * (b[..., 2] - b[..., 0]), 0.5 * (b[..., 3] - b[..., 1])
    out = np.empty(b.shape[:-1] + (3, 3))
    out[..., 0, 0] = a * a - x0 * x0
    out[..., 1, 1] = c * c - y0 * y0
    out[..., 0, 1] = out[..., 1, 0] = -x0 * y0
    out[..., 0, 2] = out[..., 2, 0] = -x0
    out[..., 1, 2] = out[..., 2, 1] = -y0
    out[..., 2, 2] = -1.0
    return out


def conic_map(P: ArrayLike) -> NDArray[np.float64]:
    """``G`` (..., 6, 10): ``vech(P Q* P^T) = G vech(Q*)`` for camera matrices ``P`` (..., 3, 4).

    Column ``k`` of ``G`` is ``vech(P E_k P^T)`` for the symmetric basis matrix ``E_k`` of ``VECH4[k]``
    (ones at ``(i, j)`` and ``(j, i)``), i.e. ``vech(p_i p_j^T + p_j p_i^T)`` for columns ``p`` of ``P``
    (``p_i p_i^T`` when ``i == j``).
    """
    P = np.asarray(P, dtype=float)
    cols = []
    for i, j in VECH4:
        outer = P[..., :, i, None] * P[..., None, :, j]
        cols.append(vech(outer if i == j else outer + np.swapaxes(outer, -1, -2)))
    return np.stack(cols, axis=-1)


def image_normalisation(width: int, height: int) -> NDArray[np.float64]:
    """The similarity ``H`` (3, 3) of a view's image coordinates: the image centre to the origin, the
    mean half side ``(width + height) / 4`` to 1 (one per view, shared by all its boxes)."""
    s = 0.25 * (width + height)
    return np.array([[1.0 / s, 0.0, -0.5 * width / s], [0.0, 1.0 / s, -0.5 * height / s], [0.0, 0.0, 1.0]])


def space_normalisation(P: ArrayLike) -> NDArray[np.float64]:
    """The 3D similarity ``S`` (4, 4), ``X' = S X``: the centroid of the camera centres to the origin, their
    mean distance from it to 1 (invariant to where the base frame's origin is and to its unit).

    Parameters
    ----------
    P : array_like, shape (n, 3, 4), camera matrices, n >= 2 views from distinct positions
    """
    P = np.asarray(P, dtype=float)
    centres = -np.linalg.solve(P[:, :, :3], P[:, :, 3:])[..., 0]  # camera centres, base frame
    c0 = centres.mean(axis=0)
    spread = float(np.mean(np.linalg.norm(centres - c0, axis=1)))
    if not spread > 0:  # all views from one position: depth is not fixed anyway; keep the scale
        spread = 1.0
    S = np.eye(4) / spread
    S[:3, 3] = -c0 / spread
    S[3, 3] = 1.0
    return S


def solve_dual_quadric(
    P: ArrayLike, bbox_xyxy: ArrayLike, image_size: tuple[int, int]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """LfD's closed-form dual quadric of one object from its boxes in ``n >= 3`` views.

    Parameters
    ----------
    P : array_like, shape (n, 3, 4), camera matrices ``K [R_optical_base | t_optical_base]``, pixels
    bbox_xyxy : array_like, shape (n, 4), the object's box in each view, pixels
    image_size : (width, height), pixels (for the image normalisation)

    Returns
    -------
    Q_star : ndarray, shape (4, 4), base frame, scaled so that ``Q*[3, 3] = -1`` (NaN when that entry is 0)
    singular_values : ndarray, shape (10 + n,), of the preconditioned system, descending (the last
        one measures how far the boxes are from a common ellipsoid)

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> from monovisual3d.camera import Camera
    >>> from monovisual3d.geometry.ellipsoid import Ellipsoid
    >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    >>> e = Ellipsoid.sphere([0.0, 0.0, 0.0], 0.05)
    >>> T = [look_at([np.cos(a), np.sin(a), 0.3], [0, 0, 0]) for a in (0.0, 1.0, 2.0)]
    >>> P = np.stack([camera_matrix(cam, t) for t in T])
    >>> Q, _ = solve_dual_quadric(P, np.stack([e.bbox(cam, t) for t in T]), (640, 480))
    >>> np.round(-Q[:3, 3], 6) + 0.0  # the centre
    array([0., 0., 0.])
    """
    P = np.asarray(P, dtype=float)
    b = np.asarray(bbox_xyxy, dtype=float)
    n = len(b)
    if P.shape != (n, 3, 4) or b.shape != (n, 4):
        raise InputError(f"quadric: expected cameras (n, 3, 4) and boxes (n, 4), got {P.shape} and {b.shape}")
    if n < MIN_VIEWS:
        raise InputError(f"quadric: {n} views, expected at least {MIN_VIEWS} to fix a dual quadric")
    H = image_normalisation(*image_size)
    S = space_normalisation(P)
    Pn = H @ P @ np.linalg.inv(S)  # P' = H P S^-1, so that P' (S Q* S^T) P'^T = H (P Q* P^T) H^T
    Cn = H @ inscribed_dual_conic(b) @ H.T
    M = np.zeros((6 * n, 10 + n))
    M[:, :10] = conic_map(Pn).reshape(6 * n, 10)
    for i in range(n):
        M[6 * i : 6 * i + 6, 10 + i] = -vech(Cn[i])
    _, sv, Vt = np.linalg.svd(M)
    Qn = unvech4(Vt[-1, :10])
    Sinv = np.linalg.inv(S)
    Q = Sinv @ Qn @ Sinv.T
    with np.errstate(divide="ignore", invalid="ignore"):
        Q = Q / -Q[3, 3] if Q[3, 3] != 0 else np.full((4, 4), np.nan)
    return Q, sv


def camera_matrix(camera: Camera, T_base_optical: ArrayLike) -> NDArray[np.float64]:
    """``P = K [R_optical_base | t_optical_base]`` (3, 4), pixels, of the pinhole part of ``camera`` at a view pose (4, 4)."""
    T = np.asarray(T_base_optical, dtype=float)
    K = np.array([[camera.fx, 0.0, camera.cx], [0.0, camera.fy, camera.cy], [0.0, 0.0, 1.0]])
    R = T[:3, :3].T
    return K @ np.hstack([R, -R @ T[:3, 3:4]])
