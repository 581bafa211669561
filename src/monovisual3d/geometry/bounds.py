"""Cramer-Rao bound of the box-edge model for ellipsoids (spheres, spheroids, ellipsoids).

The observations are the four edges of the object's box in each view that
detected it; the noise is that of the simulator (:mod:`monovisual3d.sim.noise`):
with ``sigma = box_sigma`` and a box of width ``w``, the edges ``x1, x2`` have
covariance ``sigma^2 w^2 [[1.25, 0.75], [0.75, 1.25]]`` (likewise ``y1, y2``
with the height), plus an optional independent ``edge_sigma_px`` per edge. The
Fisher information of the parameters ``theta`` is ``sum_views J^T C^-1 J`` with
``J`` the derivative of the edges (central differences of the exact box of
:func:`~monovisual3d.geometry.ellipsoid.ellipsoid_bbox`); its inverse bounds
the covariance of any unbiased estimator. Edges that the image border clips
carry no information about the object and are left out (truncation).

Occlusion (censoring): an edge of a box that an occluder (a leaf, another fruit)
cuts lies where the occluder's outline crosses the object, a place the estimator
does not know; we take it as an unknown nuisance value per cut edge, so the edge
carries no information on the object and is left out, like a clipped one
(``censored``, :func:`cut_edges`). The edge noise then scales with the box the
detector reports (the visible one, ``noise_boxes_xyxy``), not with the full silhouette.
False-positive boxes are no part of an object's boxes: with the true association
they add nothing to its bound.

Parameters of each model (``theta``, around the true object):

- ``sphere``: centre (3), one size that moves all semi-axes together (1);
- ``spheroid``: centre (3), the first two semi-axes together and the third (2);
  orientation known (the upright model: symmetry axis along ``up``);
- ``ellipsoid``: centre (3), three semi-axes (3), yaw about ``up`` (1);

with ``free_orientation`` the spheroid gains two tilts (rotations about its
first two axes) and the ellipsoid three base-frame rotation angles instead of the yaw.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError
from .ellipsoid import SHAPES, Ellipsoid, ellipsoid_bbox
from .orientation import DEFAULT_UP, check_up

#: Finite-difference steps: metres for centre and sizes, radians for angles.
STEP_M = 1e-6
STEP_RAD = 1e-6
#: An edge within this many pixels of the image border counts as clipped.
BORDER_PX = 0.5
#: A visible-box edge more than this many pixels inside the full silhouette box is cut (occluded); the
#: rendered box of whole pixels lies up to 1 px inside the exact one.
CUT_PX = 1.5
#: A parameter whose edges move by less than this (pixels per metre or radian, over all views) is not observable.
BLIND_PX = 1e-3


@dataclass(frozen=True)
class ShapeBound:
    """The Cramer-Rao bound of one object.

    Attributes
    ----------
    names : tuple of str, the parameters (``x, y, z``, then sizes ``r`` / ``a, b, c`` / ``ab, c``, then angles)
    fisher : ndarray, shape (P, P), Fisher information (units of the parameters^-2)
    covariance : ndarray, shape (P, P), its inverse; all NaN when singular (too few views or edges),
        NaN rows and columns for parameters the boxes cannot see (the yaw of a body of revolution)
    n_views : int, views with at least one usable edge
    """

    names: tuple[str, ...]
    fisher: NDArray[np.float64]
    covariance: NDArray[np.float64]
    n_views: int

    @property
    def centre_rms_sq(self) -> float:
        """Trace of the centre block (m^2): the bound on the mean squared Euclidean centre error."""
        return float(np.trace(self.covariance[:3, :3]))

    @property
    def size_rms(self) -> float:
        """RMS over the size parameters of their standard-deviation bounds (metres)."""
        idx = [i for i, n in enumerate(self.names) if n in ("r", "a", "b", "c", "ab")]
        return float(np.sqrt(np.mean(np.diag(self.covariance)[idx])))


def box_edge_covariance(boxes_xyxy: ArrayLike, box_sigma: float, edge_sigma_px: float = 0.0) -> NDArray[np.float64]:
    """Covariance (..., 4, 4) of the edges of boxes (..., 4) under the simulator's relative box noise.

    Examples
    --------
    >>> box_edge_covariance([0.0, 0.0, 100.0, 50.0], 0.05)[:2, [0, 2]]
    array([[31.25, 18.75],
           [ 0.  ,  0.  ]])
    """
    b = np.asarray(boxes_xyxy, dtype=float)
    out = np.zeros(b.shape[:-1] + (4, 4))
    block = np.array([[1.25, 0.75], [0.75, 1.25]])
    for i, j in ((0, 2), (1, 3)):
        s2 = (box_sigma * (b[..., j] - b[..., i])) ** 2
        out[..., [i, i, j, j], [i, j, i, j]] = s2[..., None] * block.reshape(4)
    out += edge_sigma_px**2 * np.eye(4)
    return out


def shape_parameters(model: str, *, free_orientation: bool = False) -> tuple[str, ...]:
    """Names of the parameters ``theta`` of a model (see the module docstring)."""
    if model not in SHAPES:
        raise InputError(f"model: got {model!r}, expected one of {list(SHAPES)}")
    names = ["x", "y", "z"]
    names += {"sphere": ["r"], "spheroid": ["ab", "c"], "ellipsoid": ["a", "b", "c"]}[model]
    if model == "ellipsoid":
        names += ["rx", "ry", "rz"] if free_orientation else ["yaw"]
    elif model == "spheroid" and free_orientation:
        names += ["tilt_a", "tilt_b"]
    return tuple(names)


def perturbed(
    ellipsoid: Ellipsoid, delta: ArrayLike, model: str, *, up: ArrayLike = DEFAULT_UP, free_orientation: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Centres (K, 3), semi-axes (K, 3) and rotations (K, 3, 3) of ``ellipsoid`` moved by ``delta`` (K, P)."""
    names = shape_parameters(model, free_orientation=free_orientation)
    d = np.atleast_2d(np.asarray(delta, dtype=float))
    if d.shape[-1] != len(names):
        raise InputError(f"delta: expected {len(names)} parameters {list(names)}, got {d.shape[-1]}")
    centres = ellipsoid.centre_base + d[:, :3]
    s = np.repeat(ellipsoid.semi_axes[None], len(d), axis=0)
    R0 = ellipsoid.rotation
    rotvec = np.zeros((len(d), 3))
    for k, name in enumerate(names[3:], start=3):
        col = d[:, k]
        if name == "r":
            s += col[:, None]
        elif name == "ab":
            s[:, :2] += col[:, None]
        elif name in ("a", "b", "c"):
            s[:, "abc".index(name)] += col
        elif name == "yaw":
            rotvec += col[:, None] * check_up(up)
        elif name in ("rx", "ry", "rz"):
            rotvec[:, "xyz".index(name[1])] += col
        else:  # tilt_a, tilt_b: about the first / second axis
            rotvec += col[:, None] * R0[:, 0 if name == "tilt_a" else 1]
    from scipy.spatial.transform import Rotation  # on first use: scipy.spatial takes 0.2-0.4 s to import

    R = Rotation.from_rotvec(rotvec).as_matrix() @ R0
    return centres, s, R


def ellipsoid_box_jacobian(
    camera: Camera,
    T_base_optical: ArrayLike,
    ellipsoid: Ellipsoid,
    model: str = "ellipsoid",
    *,
    up: ArrayLike = DEFAULT_UP,
    free_orientation: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unclipped boxes (V, 4) and their derivatives (V, 4, P) with respect to the model's parameters.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (V, 4, 4), the views
    ellipsoid : Ellipsoid, the true object
    model : ``sphere``, ``spheroid`` or ``ellipsoid``
    up : array_like, shape (3,), the vertical (yaw axis)
    free_orientation : bool, see the module docstring

    Returns
    -------
    boxes_xyxy : ndarray, shape (V, 4), pixels
    J : ndarray, shape (V, 4, P), pixels per unit of each parameter (metres, radians)
    """
    names = shape_parameters(model, free_orientation=free_orientation)
    T = np.asarray(T_base_optical, dtype=float).reshape(-1, 4, 4)
    P = len(names)
    steps = np.array([STEP_RAD if n.startswith(("r", "t", "yaw")) and n != "r" else STEP_M for n in names])
    delta = np.concatenate([np.zeros((1, P)), np.diag(steps), -np.diag(steps)])
    c, s, R = perturbed(ellipsoid, delta, model, up=up, free_orientation=free_orientation)
    boxes = ellipsoid_bbox(camera, T[:, None], c[None], s[None], R[None], clip=False)  # (V, 1 + 2P, 4)
    J = (boxes[:, 1 : 1 + P] - boxes[:, 1 + P :]) / (2 * steps[None, :, None])
    return boxes[:, 0], np.swapaxes(J, 1, 2)


def ellipsoid_crlb(
    camera: Camera,
    T_base_optical: ArrayLike,
    ellipsoid: Ellipsoid,
    box_sigma: float,
    model: str = "ellipsoid",
    *,
    edge_sigma_px: float = 0.0,
    up: ArrayLike = DEFAULT_UP,
    free_orientation: bool = False,
    censored: ArrayLike | None = None,
    noise_boxes_xyxy: ArrayLike | None = None,
) -> ShapeBound:
    """Cramer-Rao bound of an ellipsoid's parameters from its boxes in the given views.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (V, 4, 4), the views that detected the object (true poses)
    ellipsoid : Ellipsoid, the true object
    box_sigma : float, relative box noise (paper: 0.05)
    model : ``sphere``, ``spheroid`` or ``ellipsoid`` (the estimator's model)
    edge_sigma_px : float, extra independent noise per edge, pixels
    up : array_like, shape (3,), the vertical
    free_orientation : bool, see the module docstring
    censored : array_like of bool, shape (V, 4), optional
        True for edges cut by an occluder (:func:`cut_edges`): left out, like edges the border clips
    noise_boxes_xyxy : array_like, shape (V, 4), pixels, optional
        The boxes the relative noise scales with (the visible boxes); default the full silhouette boxes

    Returns
    -------
    ShapeBound

    Examples
    --------
    >>> from monovisual3d.sim.viewpoints import paper_poses
    >>> cam = Camera.from_hfov(640, 480, 69.0)
    >>> e = Ellipsoid.spheroid([0.6, 0.0, 0.45], 0.022, 0.09)
    >>> b = ellipsoid_crlb(cam, paper_poses(), e, 0.05, "spheroid")
    >>> b.names, round(float(np.sqrt(b.centre_rms_sq)) * 1e3, 1)
    (('x', 'y', 'z', 'ab', 'c'), 6.7)
    """
    if not (box_sigma >= 0 and edge_sigma_px >= 0 and box_sigma + edge_sigma_px > 0):
        raise InputError(f"box_sigma, edge_sigma_px: got {box_sigma!r}, {edge_sigma_px!r}, expected >= 0 and not both 0")
    names = shape_parameters(model, free_orientation=free_orientation)
    boxes, J = ellipsoid_box_jacobian(camera, T_base_optical, ellipsoid, model, up=up, free_orientation=free_orientation)
    C = box_edge_covariance(boxes if noise_boxes_xyxy is None else _check_vx4(noise_boxes_xyxy, boxes), box_sigma, edge_sigma_px)
    usable = _usable_edges(camera, boxes, J)
    if censored is not None:
        usable &= ~_check_vx4(censored, boxes).astype(bool)
    F, n_views = _fisher_information(J, C, usable)
    cov = _covariance_of_seen(F, J, usable) if n_views else np.full_like(F, np.nan)
    return ShapeBound(names, F, cov, n_views)


def _check_vx4(values: ArrayLike, boxes: NDArray[np.float64]) -> NDArray[np.float64]:
    """``values`` as an array of the views' box shape (V, 4), or one clear error."""
    v = np.asarray(values)
    if v.shape != boxes.shape:
        raise InputError(f"censored, noise_boxes_xyxy: expected shape {boxes.shape} (views, 4 edges), got {v.shape}")
    return v


def cut_edges(full_boxes_xyxy: ArrayLike, seen_boxes_xyxy: ArrayLike, tol_px: float = CUT_PX) -> NDArray[np.bool_]:
    """Edges of the seen (visible) boxes that lie more than ``tol_px`` inside the full silhouette boxes.

    Parameters
    ----------
    full_boxes_xyxy : array_like, shape (..., 4), pixels, the unoccluded silhouette boxes (unclipped)
    seen_boxes_xyxy : array_like, shape (..., 4), pixels, the boxes of the visible pixels
    tol_px : float, pixels

    Returns
    -------
    ndarray of bool, shape (..., 4): True where an occluder or the image border cuts the edge

    Examples
    --------
    >>> cut_edges([0.0, 0.0, 100.0, 50.0], [0.5, 20.0, 100.0, 50.0])
    array([False,  True, False, False])
    """
    full = np.asarray(full_boxes_xyxy, dtype=float)
    seen = np.asarray(seen_boxes_xyxy, dtype=float)
    inside = np.concatenate([seen[..., :2] - full[..., :2], full[..., 2:] - seen[..., 2:]], axis=-1)
    return inside > tol_px


def _usable_edges(camera: Camera, boxes: NDArray[np.float64], J: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Box edges that carry information: finite, more than :data:`BORDER_PX` inside the image, finite Jacobian.

    Parameters
    ----------
    camera : Camera
    boxes : ndarray, shape (V, 4), unclipped boxes ``x1, y1, x2, y2``, pixels
    J : ndarray, shape (V, 4, P), pixels per unit of each parameter

    Returns
    -------
    ndarray of bool, shape (V, 4)
    """
    size = np.array([camera.width, camera.height], dtype=float)
    unclipped = np.concatenate([boxes[:, :2] > BORDER_PX, boxes[:, 2:] < size - BORDER_PX], axis=1)
    return np.isfinite(boxes) & unclipped & np.all(np.isfinite(J), axis=2)


def _fisher_information(
    J: NDArray[np.float64], C: NDArray[np.float64], usable: NDArray[np.bool_]
) -> tuple[NDArray[np.float64], int]:
    """Fisher information of the parameters, summed over the views' usable edges.

    Parameters
    ----------
    J : ndarray, shape (V, 4, P), pixels per unit of each parameter
    C : ndarray, shape (V, 4, 4), covariance of the box edges, pixels^2
    usable : ndarray of bool, shape (V, 4), :func:`_usable_edges`

    Returns
    -------
    F : ndarray, shape (P, P)
    n_views : int, views with at least one usable edge
    """
    P = J.shape[2]
    F = np.zeros((P, P))
    n_views = 0
    for b_ok, Jv, Cv in zip(usable, J, C):
        if not b_ok.any():
            continue
        n_views += 1
        idx = np.flatnonzero(b_ok)
        Ji = Jv[idx]
        F += Ji.T @ np.linalg.solve(Cv[np.ix_(idx, idx)], Ji)
    return F, n_views


def _covariance_of_seen(F: NDArray[np.float64], J: NDArray[np.float64], usable: NDArray[np.bool_]) -> NDArray[np.float64]:
    """The bound ``F^-1`` over the parameters the boxes see; NaN rows and columns for the others, all NaN if singular.

    Parameters the boxes cannot see at all (the yaw of a body of revolution about its axis) are
    left out: their bound is NaN and they do not spoil the others'.

    Parameters
    ----------
    F : ndarray, shape (P, P), :func:`_fisher_information`
    J : ndarray, shape (V, 4, P), pixels per unit of each parameter
    usable : ndarray of bool, shape (V, 4)

    Returns
    -------
    ndarray, shape (P, P)
    """
    J_used = np.where(usable[..., None], J, 0.0)
    seen = np.sqrt(np.sum(J_used**2, axis=(0, 1))) > BLIND_PX
    cov = np.full_like(F, np.nan)
    k = np.flatnonzero(seen)
    Fk = F[np.ix_(k, k)]
    if len(k) and np.linalg.matrix_rank(Fk, tol=1e-12 * max(np.abs(Fk).max(), 1e-300)) == len(k):
        cov[np.ix_(k, k)] = np.linalg.inv(Fk)
    return cov


def centre_crlb_rms_sq(
    camera: Camera,
    ellipsoids: Sequence[Ellipsoid],
    poses: Sequence[ArrayLike],
    box_sigma: float,
    model: str = "ellipsoid",
    **options: object,
) -> list[float]:
    """Per object: the centre bound (m^2, :attr:`ShapeBound.centre_rms_sq`) from its own views; NaN entries dropped.

    Parameters
    ----------
    camera : Camera
    ellipsoids : sequence of Ellipsoid, the true objects
    poses : sequence of array_like, shape (V_i, 4, 4), the true poses of the views that detected object i
    box_sigma : float
    model : str
    **options : passed to :func:`ellipsoid_crlb` (``edge_sigma_px``, ``up``, ``free_orientation``)

    Returns
    -------
    list of float, one per object with a finite bound (the benchmark's RMS bound is ``sqrt(mean(...))``)
    """
    if len(ellipsoids) != len(poses):
        raise InputError(f"poses: got {len(poses)} pose lists for {len(ellipsoids)} objects, expected one per object")
    out = []
    for e, P in zip(ellipsoids, poses):
        P = np.asarray(P, dtype=float).reshape(-1, 4, 4)
        if len(P) == 0:
            continue
        v = ellipsoid_crlb(camera, P, e, box_sigma, model, **options).centre_rms_sq  # type: ignore[arg-type]
        if np.isfinite(v):
            out.append(v)
    return out
