"""Which sides of a box a nearer box hides: the box geometry of occlusion, for every pass that judges a cut.

Pure functions of boxes (``bbox_xyxy``, pixels): :func:`occluded_edges` asks whether a nearer box covers the extreme
point that sets an edge (a round fruit's outline), :func:`covered_sides` whether it covers the whole side (a tall
object's edge stays while any part of its side shows), :func:`spans` whether it spans a side, :func:`ends_at_occluder`
whether an observed edge ends at the nearer box's facing edge (a box of the visible part), and :func:`boxes_meet`
whether two observed boxes stand side by side as one object hiding part of another.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .sensor import SensorModel, box_edge_sigma_px

#: An observed edge ends at an occluder when it lies within this many edge-noise sigmas (plus the occluder's
#: uncertainty) of the occluder's facing edge (:func:`ends_at_occluder`).
EDGE_AT_OCCLUDER_SIGMAS = 3.0


def occluded_edges(pred: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike = 0.0) -> NDArray[np.bool_]:
    """Edges ``x1, y1, x2, y2`` of an object's box that a nearer object hides, shape (4,).

    The edge of a convex silhouette's box is set by its extreme point on that side; the box is cut there
    when a nearer silhouette covers that point. Silhouettes are taken as the ellipses inscribed in the
    predicted boxes (exact for a sphere seen on the optical axis, close to it in a usual field of view).

    Parameters
    ----------
    pred : ndarray, shape (4,), the object's predicted box, pixels
    nearer : ndarray, shape (N, 4), predicted boxes of the objects nearer the camera, pixels
    margin_px : float or ndarray, shape (N, 2), pixels: a point counts as covered only this far inside a nearer
        silhouette (its half-width and half-height shrunk by it), so that the noise of the estimates does not
        censor a full edge

    Examples
    --------
    >>> occluded_edges(np.array([10.0, 0, 50, 40]), np.array([[40.0, 5, 80, 30]])).tolist()
    [False, False, True, False]
    """
    return occluded_pairs(*_against(pred, nearer, margin_px)).any(axis=0)


def _against(
    box: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``box`` (4,) paired with each of ``nearer`` (N, 4), with the margins (N, 2): the pairwise tests' arguments."""
    nearer = np.asarray(nearer, dtype=float).reshape(-1, 4)
    m = np.broadcast_to(np.asarray(margin_px, dtype=float), (len(nearer), 2))
    return np.broadcast_to(np.asarray(box, dtype=float), nearer.shape), nearer, m


def _finite_pairs(*boxes: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Pairs (P,) whose boxes (each (P, 4)) are all finite: a box with a NaN flags nothing."""
    return np.logical_and.reduce([np.all(np.isfinite(b), axis=1) for b in boxes])


def occluded_pairs(pred: NDArray[np.float64], nearer: NDArray[np.float64], margin: NDArray[np.float64]) -> NDArray[np.bool_]:
    """:func:`occluded_edges` pair by pair: the edges (P, 4) of each box ``pred`` (P, 4) whose extreme point the
    silhouette of its ``nearer`` box (P, 4), shrunk by ``margin`` (P, 2), covers."""
    x1, y1, x2, y2 = pred.T
    cx, cy = (x1 + x2) / 2, (y1 + y2) / 2
    points = np.stack([np.stack(p, axis=-1) for p in ((x1, cy), (cx, y1), (x2, cy), (cx, y2))], axis=1)  # (P, 4, 2)
    centre = (nearer[:, :2] + nearer[:, 2:]) / 2
    half = np.maximum((nearer[:, 2:] - nearer[:, :2]) / 2 - margin, 1e-9)
    with np.errstate(invalid="ignore"):  # NaN boxes: ruled out below
        inside = np.sum(((points - centre[:, None]) / half[:, None]) ** 2, axis=2) < 1.0
    return inside & _finite_pairs(pred, nearer)[:, None]


def covered_sides(pred: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike = 0.0) -> NDArray[np.bool_]:
    """Edges ``x1, y1, x2, y2`` of an object's box along which a nearer box covers the whole side, shape (4,).

    The stricter test of :func:`occluded_edges` for the shape fits: a tall object's box edge is set by a whole side
    of its outline, not one extreme point, and stays where it is while any part of that side shows (a farther
    container's top above a nearer one). A nearer box (N, 4), shrunk by ``margin_px`` ((N, 2) or scalar, pixels),
    must reach across the edge, and span the box's whole extent along it to within the margin.

    Examples
    --------
    >>> covered_sides(np.array([100.0, 50, 160, 200]), np.array([[150.0, 40, 230, 210]])).tolist()
    [False, False, True, False]
    >>> covered_sides(np.array([100.0, 50, 160, 200]), np.array([[150.0, 60, 230, 210]])).tolist()  # its top shows
    [False, False, False, False]
    """
    return covered_pairs(*_against(pred, nearer, margin_px)).any(axis=0)


def spans(box: NDArray[np.float64], nearer: NDArray[np.float64], tolerance_px: ArrayLike) -> NDArray[np.bool_]:
    """Whether a nearer box reaches over a box's whole height (column 0) and whole width (column 1), shape (P, 2):
    each of ``nearer`` (P, 4) against ``box`` (P, 4), where a side of ``box`` sticking out by up to ``tolerance_px``
    ((P, 4) per edge, or broadcastable, pixels) counts as covered (it would not be seen beyond the edge noise).

    Examples
    --------
    >>> spans(np.array([[100.0, 50, 160, 200]]), np.array([[150.0, 52, 230, 210]]), 3.0).tolist()
    [[True, False]]
    """
    box, n = np.asarray(box, dtype=float).reshape(-1, 4), np.asarray(nearer, dtype=float).reshape(-1, 4)
    tol = np.broadcast_to(np.asarray(tolerance_px, dtype=float), n.shape)
    spans_y = (n[:, 1] - tol[:, 1] <= box[:, 1]) & (n[:, 3] + tol[:, 3] >= box[:, 3])
    spans_x = (n[:, 0] - tol[:, 0] <= box[:, 0]) & (n[:, 2] + tol[:, 2] >= box[:, 2])
    return np.stack([spans_y, spans_x], axis=1)


def covered_pairs(pred: NDArray[np.float64], n: NDArray[np.float64], m: NDArray[np.float64]) -> NDArray[np.bool_]:
    """:func:`covered_sides` pair by pair: the edges (P, 4) of each box ``pred`` (P, 4) whose whole side its nearer
    box ``n`` (P, 4), with the margin ``m`` (P, 2), covers."""
    x1, y1, x2, y2 = pred.T
    nx1, ny1, nx2, ny2 = n[:, 0] + m[:, 0], n[:, 1] + m[:, 1], n[:, 2] - m[:, 0], n[:, 3] - m[:, 1]
    # spanning is judged with the margin the other way: a side sticking out by less than the noise is not seen
    spans_y, spans_x = spans(pred, n, m[:, [0, 1, 0, 1]]).T
    out = np.stack(
        [
            spans_y & (nx1 < x1) & (nx2 > x1),
            spans_x & (ny1 < y1) & (ny2 > y1),
            spans_y & (nx1 < x2) & (nx2 > x2),
            spans_x & (ny1 < y2) & (ny2 > y2),
        ],
        axis=1,
    )
    return out & _finite_pairs(pred, n)[:, None]


def ends_at_occluder(
    observed: NDArray[np.float64], nearer: NDArray[np.float64], margin_px: ArrayLike, sigma_px: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Edges ``x1, y1, x2, y2`` of an observed box that lie where a nearer box (N, 4) begins, shape (4,): within
    ``margin_px`` ((N, 2) or scalar, the nearer box's uncertainty) plus :data:`EDGE_AT_OCCLUDER_SIGMAS` times the edge
    noise ``sigma_px`` (4,) of the facing edge (the left edge of a box to the nearer one's right edge, and so on).

    A detector of visible parts ends a box where the occluder begins; an edge well inside the occluder's box is the
    object's own edge drawn through the occluder (an amodal box, as an annotator draws it), and carries its position.

    Examples
    --------
    >>> sigma = np.full(4, 2.0)
    >>> ends_at_occluder(np.array([100.0, 50, 150, 200]), np.array([[150.0, 40, 230, 210]]), 0.0, sigma).tolist()
    [False, False, True, False]
    >>> ends_at_occluder(np.array([100.0, 50, 190, 200]), np.array([[150.0, 40, 230, 210]]), 0.0, sigma).tolist()
    [False, False, False, False]
    """
    obs, n, m = _against(observed, nearer, margin_px)
    return ends_pairs(obs, n, m, np.broadcast_to(np.asarray(sigma_px, dtype=float), n.shape)).any(axis=0)


def ends_pairs(
    observed: NDArray[np.float64], n: NDArray[np.float64], m: NDArray[np.float64], sigma: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """:func:`ends_at_occluder` pair by pair: boxes ``observed`` (P, 4) with edge noise ``sigma`` (P, 4), nearer boxes
    ``n`` (P, 4) with margins ``m`` (P, 2)."""
    tol = m[:, [0, 1, 0, 1]] + EDGE_AT_OCCLUDER_SIGMAS * sigma
    facing = n[:, [2, 3, 0, 1]]  # the nearer box's edge facing each edge of the observed box
    with np.errstate(invalid="ignore"):
        return (np.abs(facing - observed) <= tol) & _finite_pairs(observed, n)[:, None]


def boxes_near(boxes: NDArray[np.float64], pad_px: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which of the boxes (N, 4), each widened by its ``pad_px`` (N, 2) along x and y, meet each other (closed
    intervals), shape (N, N); False on the diagonal and for a box with a NaN.

    The tests of :func:`occlusion_flags` flag an edge only where the nearer box, shrunk or grown by the pair's margin
    ``OCCLUSION_MARGIN_SIGMAS * hypot(std_i, std_j)`` (at most the sum of the two pads), reaches into the box or
    spans it: boxes that do not meet so widened have no flag to give each other.
    """
    lo, hi = boxes[:, :2] - pad_px, boxes[:, 2:] + pad_px
    out = np.all((lo[:, None, :] <= hi[None, :, :]) & (hi[:, None, :] >= lo[None, :, :]), axis=2)
    np.fill_diagonal(out, False)
    return out


#: Boxes of two objects stand side by side when they share at least this fraction of the lower one's height.
MIN_SHARED_HEIGHT = 0.5


#: Boxes of two objects meet in a view when they overlap, or when their facing edges are within this many edge sigmas.
MEET_SIGMAS = 2.0


def boxes_meet(model: SensorModel, a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether two observed boxes (4,), pixels, stand side by side as one object hiding part of another does: they
    share at least :data:`MIN_SHARED_HEIGHT` of the lower one's height and overlap, or abut within :data:`MEET_SIGMAS`
    edge sigmas (of the narrower one, under the sensor model ``model``), across."""
    shared = min(a[3], b[3]) - max(a[1], b[1])
    if shared < MIN_SHARED_HEIGHT * min(a[3] - a[1], b[3] - b[1]):
        return False
    sigma = float(np.min(box_edge_sigma_px(model, np.stack([a, b]))[:, 0]))
    return bool(min(a[2], b[2]) - max(a[0], b[0]) > -MEET_SIGMAS * sigma)
