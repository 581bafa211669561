"""Which box edges a shape fit uses, and how: seen (finite, off the image border, not hidden by a nearer object),
hidden (at the image border, or behind a nearer object: one-sided, the object reaches at least that far), and the
noise of each.

An edge on the image border or one a nearer object hides (``censored``) is not the object's edge, but the object
continues beyond it, so a prediction inside that edge is wrong while one beyond it says nothing
(:func:`one_sided_edges`); the ``bayes`` sensor model and its sphere refit count such edges the same way
(``methods.bayes.likelihood``, ``methods.bayes.refine``). Hidden edges are not counted in a fit's ``n_edges``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError

#: sqrt(1.25): per-edge std of the simulator's relative box noise, in units of box_sigma * size.
EDGE_NOISE_FACTOR = math.sqrt(1.25)


def usable_edges(
    camera: Camera,
    T_base_optical: ArrayLike,
    boxes_xyxy: ArrayLike,
    names: tuple[str, ...],
    shape: str,
    box_sigma: float,
    edge_sigma_px: float,
    border_px: float,
    censored: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """Poses (K, 4, 4), boxes (K, 4), the mask (K, 4) of edges used (finite, off the image border, not ``censored``)
    and the noise sigma (E,) of each used edge, pixels; checks there are enough edges for ``names``."""
    if not (box_sigma >= 0 and edge_sigma_px >= 0 and box_sigma + edge_sigma_px > 0):
        raise InputError(f"box_sigma, edge_sigma_px: got {box_sigma!r}, {edge_sigma_px!r}, expected >= 0 and not both 0")
    T = np.asarray(T_base_optical, dtype=float).reshape(-1, 4, 4)
    b = np.asarray(boxes_xyxy, dtype=float).reshape(-1, 4)
    if len(T) != len(b):
        raise InputError(f"boxes_xyxy: got {len(b)} boxes for {len(T)} poses, expected one box per view")
    used = np.isfinite(b) & _off_border(camera, b, border_px) & ~_flags(censored, b)
    n_edges = int(used.sum())
    if n_edges < len(names):
        raise InputError(
            f"boxes_xyxy: {n_edges} usable box edges (finite, off the image border, not censored) cannot fix the "
            f"{len(names)} parameters of a {shape}"
        )
    return T, b, used, edge_noise_px(b, box_sigma, edge_sigma_px)[used]


def edge_noise_px(b: NDArray[np.float64], box_sigma: float, edge_sigma_px: float) -> NDArray[np.float64]:
    """The noise std of every edge of the boxes ``b`` (K, 4), pixels, shape (K, 4)."""
    wh = np.concatenate([b[:, 2:] - b[:, :2]] * 2, axis=1)
    return np.sqrt((EDGE_NOISE_FACTOR * box_sigma * wh) ** 2 + edge_sigma_px**2)


def hidden_edges(camera: Camera, b: NDArray[np.float64], border_px: float, censored: ArrayLike | None) -> NDArray[np.bool_]:
    """The edges (K, 4) of the boxes ``b`` that bound the object from inside only (the object reaches at least that
    far): finite ones within ``border_px`` of the image border (truncated), and the ``censored`` ones (hidden by a
    nearer object)."""
    return np.isfinite(b) & (~_off_border(camera, b, border_px) | _flags(censored, b))


def _off_border(camera: Camera, b: NDArray[np.float64], border_px: float) -> NDArray[np.bool_]:
    """Which edges (K, 4) of the boxes ``b`` lie more than ``border_px`` inside the image."""
    size = np.array([camera.width, camera.height], dtype=float)
    return np.concatenate([b[:, :2] > border_px, b[:, 2:] < size - border_px], axis=1)


def _flags(censored: ArrayLike | None, b: NDArray[np.float64]) -> NDArray[np.bool_]:
    """The ``censored`` flags (K, 4), one per edge of the boxes ``b`` (none set when None)."""
    if censored is None:
        return np.zeros(b.shape, dtype=bool)
    cut = np.asarray(censored, dtype=bool)
    if cut.shape != b.shape:
        raise InputError(f"censored: got shape {cut.shape}, expected {b.shape} (one flag per box edge)")
    return cut


def one_sided_edges(
    r: NDArray[np.float64], edge_index: NDArray[np.intp], r_limit: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Normalised residuals ``r`` (predicted minus observed, (..., E)) of hidden edges (:func:`hidden_edges`), with
    ``edge_index`` (E,) their place in a box (0-3: ``x1, y1, x2, y2``), kept only where the prediction falls inside
    the observed edge (the object reaches at least that far, behind its occluder or beyond the image border; a
    prediction beyond the edge costs nothing).

    ``r_limit`` (..., E), optional: the normalised residuals from how far the edge can be hidden (predicted minus
    that limit; NaN: no limit), kept where the prediction reaches past it. A box of an object's visible part ends
    at its occluder, and the object cannot reach past the occluder's far side, or that part would show and the box
    would hold it.

    Examples
    --------
    >>> one_sided_edges(np.array([2.0, -2.0, 2.0, -2.0]), np.array([0, 1, 2, 3])).tolist()
    [2.0, 0.0, 0.0, -2.0]
    >>> one_sided_edges(np.array([-5.0, 2.0]), np.array([0, 2]), np.array([-1.0, np.nan])).tolist()
    [-1.0, 0.0]
    """
    low_edge = np.asarray(edge_index) < 2  # x1, y1: inside means predicted > observed
    inside = np.where(low_edge, np.maximum(r, 0.0), np.minimum(r, 0.0))
    if r_limit is None:
        return inside
    past = np.where(low_edge, np.minimum(r_limit, 0.0), np.maximum(r_limit, 0.0))
    return inside + np.where(np.isfinite(past), past, 0.0)
