"""An image-tile index of each view's boxes, so that a hypothesis meets only the boxes near its predicted box.

The sensor model gates association (:func:`.likelihood.box_scores`): a box can be an object's box only
if it meets the object's predicted box widened by ``gate_sigmas`` edge-noise sigmas on every side
(occlusion shrinks a box inside the silhouette, noise moves its edges by a few sigmas; a box wholly
beside the prediction belongs to something else). So the boxes a hypothesis can take in a view are
those intersecting one rectangle, and a two-dimensional look-up finds them.

The index cuts the image into square tiles of :func:`tile_px` pixels and lists, per tile, the boxes
that overlap it (a box is listed in every tile it covers). A query rectangle visits its tiles and
reports each box once: in the tile where the box's and the query's top-left tiles meet
(``max`` of the two tile columns, and of the two rows). The compiled kernel asks once per
hypothesis cell and view, with the union of the widened boxes of the cell's shape bins, and scores
each bin against that short list. The result is the scan's over all boxes
(``tests/methods/bayes/test_boxindex.py`` checks it against the numpy reference).
A view with few boxes (:data:`SCAN_BELOW_BOXES`) is scanned: for so few, the look-up costs more than it saves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Views with at most this many boxes are scanned box by box (faster than the look-up for so few; same result).
SCAN_BELOW_BOXES = 16
#: Smallest tile side, pixels (smaller tiles list a box many times for nothing).
MIN_TILE_PX = 16.0
#: Tiles per image side at most (the tile grows on larger images).
MAX_TILES_PER_SIDE = 64


@dataclass(frozen=True)
class TileIndex:
    """Per view, the boxes overlapping each image tile (see the module docstring).

    Attributes
    ----------
    count : ndarray, shape (V,), int64: boxes per view
    tile : ndarray, shape (V,), float64: tile side, pixels
    n_cols, n_rows : ndarray, shape (V,), int64: tiles across and down the image
    start : ndarray, shape (V, T + 1), int64: the entries of tile ``t = row * n_cols + col`` of view ``v`` are
        ``entries[v, start[v, t]:start[v, t + 1]]``
    entries : ndarray, shape (V, M), int64: box indices
    corner : ndarray, shape (V, Bmax, 2), int64: each box's top-left tile (column, row), clipped to the grid
    """

    count: NDArray[np.int64]
    tile: NDArray[np.float64]
    n_cols: NDArray[np.int64]
    n_rows: NDArray[np.int64]
    start: NDArray[np.int64]
    entries: NDArray[np.int64]
    corner: NDArray[np.int64]

    def as_tuple(self) -> tuple:
        """The arrays in the order the compiled kernels unpack them."""
        return (self.count, self.tile, self.n_cols, self.n_rows, self.start, self.entries, self.corner)


def tile_px(boxes_xyxy: NDArray[np.float64], width: float, height: float) -> float:
    """Tile side for one view's boxes (B, 4): their median larger side, at least :data:`MIN_TILE_PX` and at least
    ``max(width, height) / MAX_TILES_PER_SIDE``.

    A tile about one box across lists each box in about four tiles and a query in a few.

    Examples
    --------
    >>> tile_px(np.array([[0.0, 0.0, 40.0, 30.0], [100.0, 100.0, 160.0, 200.0]]), 1280, 720)
    70.0
    """
    b = np.asarray(boxes_xyxy, dtype=np.float64).reshape(-1, 4)
    typical = float(np.median(np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]))) if len(b) else 0.0
    return max(MIN_TILE_PX, max(width, height) / MAX_TILES_PER_SIDE, typical if math.isfinite(typical) else 0.0)


def _tile_span(
    lo: NDArray[np.float64], hi: NDArray[np.float64], tile: float, n: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """First and last tile (clipped to ``0 .. n - 1``) of intervals ``[lo, hi]`` in pixels."""
    first = np.clip(np.floor(lo / tile), 0, n - 1).astype(np.int64)
    last = np.clip(np.floor(hi / tile), 0, n - 1).astype(np.int64)
    return first, np.maximum(first, last)


def build_index(boxes: list[NDArray[np.float64]], width: float, height: float) -> TileIndex:
    """The index of each view's boxes (list of (B_v, 4) ``x1, y1, x2, y2`` pixels) in a ``width x height`` image."""
    V = len(boxes)
    count = np.array([len(b) for b in boxes], dtype=np.int64)
    bmax = max(int(count.max(initial=0)), 1)
    tile, n_cols, n_rows = np.ones(V), np.ones(V, dtype=np.int64), np.ones(V, dtype=np.int64)
    corner = np.zeros((V, bmax, 2), dtype=np.int64)
    lists: list[list[NDArray[np.int64]]] = []
    for v, b in enumerate(boxes):
        b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
        tile[v] = tile_px(b, width, height)
        n_cols[v], n_rows[v] = max(1, math.ceil(width / tile[v])), max(1, math.ceil(height / tile[v]))
        c1, c2 = _tile_span(b[:, 0], b[:, 2], tile[v], int(n_cols[v]))
        r1, r2 = _tile_span(b[:, 1], b[:, 3], tile[v], int(n_rows[v]))
        corner[v, : len(b), 0], corner[v, : len(b), 1] = c1, r1
        per_tile: list[list[int]] = [[] for _ in range(int(n_cols[v] * n_rows[v]))]
        for j in range(len(b)):
            for r in range(r1[j], r2[j] + 1):
                for c in range(c1[j], c2[j] + 1):
                    per_tile[r * n_cols[v] + c].append(j)
        lists.append([np.array(t, dtype=np.int64) for t in per_tile])
    n_tiles = max(len(t) for t in lists) if lists else 1
    n_entries = max((sum(len(x) for x in t) for t in lists), default=1)
    start = np.zeros((V, n_tiles + 1), dtype=np.int64)
    entries = np.zeros((V, max(n_entries, 1)), dtype=np.int64)
    for v, per_tile in enumerate(lists):
        sizes = np.array([len(x) for x in per_tile], dtype=np.int64)
        start[v, 1 : len(sizes) + 1] = np.cumsum(sizes)
        start[v, len(sizes) + 1 :] = start[v, len(sizes)]
        if sizes.sum():
            entries[v, : sizes.sum()] = np.concatenate(per_tile)
    return TileIndex(count, tile, n_cols, n_rows, start, entries, corner)


def candidate_boxes(index: TileIndex, v: int, query_xyxy: NDArray[np.float64]) -> NDArray[np.int64]:
    """The readable twin of the compiled look-up: sorted box indices of view ``v`` listed in the tiles of the
    rectangle ``query_xyxy`` (4,), pixels, once each (a superset of the boxes meeting it; the kernels then test
    each against the gate)."""
    tile, n_cols, n_rows = float(index.tile[v]), int(index.n_cols[v]), int(index.n_rows[v])
    c1, c2 = (int(x[0]) for x in _tile_span(np.array([query_xyxy[0]]), np.array([query_xyxy[2]]), tile, n_cols))
    r1, r2 = (int(x[0]) for x in _tile_span(np.array([query_xyxy[1]]), np.array([query_xyxy[3]]), tile, n_rows))
    out = []
    for r in range(r1, r2 + 1):
        for c in range(c1, c2 + 1):
            t = r * n_cols + c
            for j in index.entries[v, index.start[v, t] : index.start[v, t + 1]]:
                if c == max(index.corner[v, j, 0], c1) and r == max(index.corner[v, j, 1], r1):
                    out.append(int(j))
    return np.array(sorted(out), dtype=np.int64)
