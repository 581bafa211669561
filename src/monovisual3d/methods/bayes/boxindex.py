"""An index of each view's boxes by edge, so that a hypothesis meets only the boxes that can matter to it.

A box scores ``match_bonus`` plus four edge terms against a predicted box
(:mod:`.likelihood`); each term costs ``min(e^2 / 2, floor)`` nats, ``e`` the
edge residual in units of the edge noise ``sigma``. A box matters only if it
scores above the miss term, i.e. its four terms cost less than
``G = match_bonus - log(p_miss)`` together. Call an edge *near* when
``|e| <= E`` with ``E^2 / 2 = G / 4`` (:func:`near_sigmas`): a far edge costs
more than ``G / 4`` (when both floors exceed ``G / 4``, as they do by default:
3 and 6 nats against 2.6), so a box with four far edges scores below the miss
term. Every box that can be associated therefore has at least one near edge.

The index holds, per view and per edge (``x1, y1, x2, y2``), the boxes sorted by
that edge's coordinate: a hypothesis looks up, by binary search, the boxes whose
edge lies within ``E sigma`` of its predicted edge, four small ranges, and scores
exactly those, as the scan over all boxes would. A censored edge (on the image
border) scores 0 whenever the predicted edge lies beyond it, so the boxes with a
censored edge are listed apart and looked at when the predicted edge crosses
that border. The result is identical to the scan (``tests/methods/bayes/test_boxindex.py``
checks it against the numpy reference); with floors at or below ``G / 4`` the
index is not valid and the kernels scan every box (``scan_all``). A view with few boxes
(:data:`SCAN_BELOW_BOXES`) is scanned too: for so few, the look-up costs more than it saves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .sensor import SensorModel

#: Relative widening of the near window (rounding of the compiled sums).
WINDOW_SLACK = 1e-6
#: Width of the buckets that start a look-up in a sorted edge list, pixels (wider when the boxes spread further).
BUCKET_PX = 8.0
#: Buckets per view and edge at most.
MAX_BUCKETS = 4096
#: Views with at most this many boxes are scanned box by box (faster than the look-up for so few; same result).
SCAN_BELOW_BOXES = 32


@dataclass(frozen=True)
class EdgeIndex:
    """Per view and edge, the boxes sorted by that edge (see the module docstring).

    Attributes
    ----------
    count : ndarray, shape (V,), int64: boxes per view
    values : ndarray, shape (V, 4, Bmax), float64: the edge coordinate, sorted, pixels (first ``count[v]`` valid)
    order : ndarray, shape (V, 4, Bmax), int64: the box index of each sorted value
    n_censored : ndarray, shape (V, 4), int64: boxes with that edge on the image border
    censored : ndarray, shape (V, 4, Bmax), int64: their indices (first ``n_censored[v, e]`` valid)
    origin, bucket : ndarray, shape (V, 4), float64: the buckets of each sorted list start at ``origin`` and
        are ``bucket`` pixels wide
    start : ndarray, shape (V, 4, NB), int64: the first position in the sorted list at or after each bucket's start
    near_sigmas : float, ``E``: half-width of the window in edge-noise units; 0 when ``scan_all``
    scan_all : bool, the floors are too low for the index: score every box
    """

    count: NDArray[np.int64]
    values: NDArray[np.float64]
    order: NDArray[np.int64]
    n_censored: NDArray[np.int64]
    censored: NDArray[np.int64]
    origin: NDArray[np.float64]
    bucket: NDArray[np.float64]
    start: NDArray[np.int64]
    near_sigmas: float
    scan_all: bool

    def as_tuple(self) -> tuple:
        """The arrays and numbers in the order the compiled kernels unpack them."""
        return (
            self.count, self.values, self.order, self.n_censored, self.censored, self.origin, self.bucket, self.start,
            self.near_sigmas, self.scan_all,
        )  # fmt: skip


def near_sigmas(model: SensorModel) -> float:
    """``E`` of the module docstring (edge-noise units), or 0 when a far edge may cost ``G / 4`` or less.

    Examples
    --------
    >>> round(near_sigmas(SensorModel()), 3)  # G = 8 + log(10) nats, E = sqrt(G / 2)
    2.27
    """
    gap = model.match_bonus - model.miss_term
    if gap <= 0:  # no box can beat a miss: any window is valid, the smallest is cheapest
        return WINDOW_SLACK
    quarter = gap / 4
    if min(model.inward_floor, model.outward_floor) <= quarter * (1 + 10 * WINDOW_SLACK):
        return 0.0
    return math.sqrt(2 * quarter) * (1 + WINDOW_SLACK)


def censored_edges(boxes_xyxy: NDArray[np.float64], width: float, height: float, border: float) -> NDArray[np.bool_]:
    """Which edges of each box (B, 4) lie on the image border: ``x1, y1 <= border``, ``x2 >= width - border``, ..."""
    b = np.asarray(boxes_xyxy, dtype=np.float64).reshape(-1, 4)
    return np.stack([b[:, 0] <= border, b[:, 1] <= border, b[:, 2] >= width - border, b[:, 3] >= height - border], axis=1)


def build_index(boxes: list[NDArray[np.float64]], width: float, height: float, model: SensorModel) -> EdgeIndex:
    """The index of each view's boxes (list of (B_v, 4) ``x1, y1, x2, y2`` pixels) for the sensor ``model``."""
    V = len(boxes)
    count = np.array([len(b) for b in boxes], dtype=np.int64)
    bmax = max(int(count.max(initial=0)), 1)
    values = np.full((V, 4, bmax), np.inf)
    order = np.zeros((V, 4, bmax), dtype=np.int64)
    n_cens = np.zeros((V, 4), dtype=np.int64)
    cens = np.zeros((V, 4, bmax), dtype=np.int64)
    origin = np.zeros((V, 4))
    bucket = np.ones((V, 4))
    starts: list[list[NDArray[np.int64]]] = [[np.zeros(1, dtype=np.int64)] * 4 for _ in range(V)]
    for v, b in enumerate(boxes):
        if count[v] == 0:
            continue
        b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
        idx = np.argsort(b, axis=0, kind="stable").T  # (4, B)
        order[v, :, : count[v]] = idx
        values[v, :, : count[v]] = np.take_along_axis(b.T, idx, axis=1)
        flags = censored_edges(b, width, height, float(model.border_px))
        for e in range(4):
            on_border = np.flatnonzero(flags[:, e])
            n_cens[v, e] = len(on_border)
            cens[v, e, : len(on_border)] = on_border
            origin[v, e], bucket[v, e], starts[v][e] = _buckets(values[v, e, : count[v]])
    start = np.zeros((V, 4, max(len(s) for row in starts for s in row)), dtype=np.int64)
    for v in range(V):
        for e in range(4):
            start[v, e, : len(starts[v][e])] = starts[v][e]
    E = near_sigmas(model)
    return EdgeIndex(count, values, order, n_cens, cens, origin, bucket, start, E, E == 0.0)


def _buckets(sorted_values: NDArray[np.float64]) -> tuple[float, float, NDArray[np.int64]]:
    """Origin, width and start positions of the buckets of one sorted list (a look-up starts at its bucket)."""
    lo, hi = float(sorted_values[0]), float(sorted_values[-1])
    width = max(BUCKET_PX, (hi - lo) / (MAX_BUCKETS - 1))
    edges = lo + width * np.arange(int((hi - lo) / width) + 1)
    return lo, width, np.searchsorted(sorted_values, edges, "left").astype(np.int64)


def candidate_boxes(
    index: EdgeIndex, v: int, pred_xyxy: NDArray[np.float64], sigma_xy: tuple[float, float], width: float, height: float,
    border: float,
) -> NDArray[np.int64]:  # fmt: skip
    """The readable twin of the compiled look-up: sorted unique box indices of view ``v`` near ``pred_xyxy`` (4,).

    ``sigma_xy``: the edge noise of the hypothesis in x and y, pixels. With ``scan_all``, every box.
    """
    n = int(index.count[v])
    if index.scan_all:
        return np.arange(n, dtype=np.int64)
    out = []
    for e in range(4):
        h = index.near_sigmas * sigma_xy[e % 2]
        vals = index.values[v, e, :n]
        a, b = np.searchsorted(vals, pred_xyxy[e] - h, "left"), np.searchsorted(vals, pred_xyxy[e] + h, "right")
        out.append(index.order[v, e, a:b])
        if _beyond_border(e, pred_xyxy[e], width, height, border):
            out.append(index.censored[v, e, : index.n_censored[v, e]])
    return np.unique(np.concatenate(out)) if out else np.zeros(0, dtype=np.int64)


def _beyond_border(e: int, pred_edge: float, width: float, height: float, border: float) -> bool:
    """Whether a censored edge ``e`` can have a positive residual, i.e. the predicted edge lies beyond the border."""
    if e < 2:
        return pred_edge < border
    return pred_edge > (width if e == 2 else height) - border
