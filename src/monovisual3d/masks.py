"""Instance masks: COCO RLE / polygon decoding and outline (contour) points.

A detection may carry ``mask``: ``{"polygon": [[u, v], ...]}`` (pixels, the
outline) or COCO run-length encoding ``{"size": [height, width], "counts": ...}``
(uncompressed list or compressed string; column-major, as pycocotools writes).
The methods use the outline's points (:func:`contour_points`); the silhouette
residual of the ``bayes`` method is in :mod:`monovisual3d.methods.bayes.masks`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .checks import is_int
from .errors import InputError

#: Contour points kept per mask.
MAX_CONTOUR_POINTS = 48


def decode_rle(rle: dict[str, Any]) -> NDArray[np.bool_]:
    """Decode COCO RLE to a boolean mask of shape (height, width).

    Examples
    --------
    >>> decode_rle({"size": [2, 2], "counts": [1, 2, 1]}).astype(int)
    array([[0, 1],
           [1, 0]])
    """
    counts = rle_counts(rle)
    h, w = (int(v) for v in rle["size"])
    flat = np.zeros(h * w, dtype=bool)
    pos = 0
    for i, c in enumerate(counts):
        if i % 2 == 1:
            flat[pos : pos + c] = True
        pos += c
    return flat.reshape(w, h).T


def rle_counts(rle: dict[str, Any]) -> list[int]:
    """The run lengths of COCO RLE, checked against its size without decoding the mask.

    Examples
    --------
    >>> rle_counts({"size": [2, 2], "counts": [1, 2, 1]})
    [1, 2, 1]
    """
    try:
        h, w = (int(v) for v in rle["size"])
    except (KeyError, TypeError, ValueError, OverflowError):
        raise InputError("mask.size: expected [height, width]") from None
    if h < 0 or w < 0:
        raise InputError("mask.size: expected [height, width], non-negative")
    counts = rle.get("counts")
    if isinstance(counts, str):
        try:
            counts = _decode_compressed_counts(counts)
        except IndexError:
            raise InputError("mask.counts: not a valid COCO compressed RLE string") from None
    if not isinstance(counts, list) or not all(is_int(c) and c >= 0 for c in counts):
        raise InputError("mask.counts: expected a list of non-negative run lengths or a COCO compressed string")
    total = sum(counts)
    if total != h * w:
        shown = f"{total}" if total < 10**30 else "a number too large"
        raise InputError(f"mask.counts: run lengths sum to {shown}, expected height*width = {h * w}")
    return counts


def encode_rle(mask: NDArray[np.bool_]) -> dict[str, Any]:
    """Encode a boolean mask (height, width) as uncompressed COCO RLE (column-major runs, starting with zeros)."""
    flat = np.asarray(mask, dtype=bool).T.ravel()
    change = np.flatnonzero(np.diff(flat.astype(np.int8))) + 1
    bounds = np.concatenate([[0], change, [flat.size]])
    runs = np.diff(bounds).tolist()
    if flat.size and flat[0]:
        runs = [0, *runs]
    return {"size": [int(mask.shape[0]), int(mask.shape[1])], "counts": [int(r) for r in runs]}


def _decode_compressed_counts(s: str) -> list[int]:
    counts: list[int] = []
    p = 0
    while p < len(s):
        x, k, more = 0, 0, True
        while more:
            c = ord(s[p]) - 48
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p += 1
            k += 1
            if not more and (c & 0x10):
                x |= -1 << (5 * k)
        if len(counts) > 2:
            x += counts[-2]
        counts.append(int(x))
    return counts


def contour_points(mask: dict[str, Any], max_points: int = MAX_CONTOUR_POINTS) -> NDArray[np.float64]:
    """Outline points of a mask, shape (M, 2), pixels (continuous edge convention)."""
    if "polygon" in mask:
        poly = np.asarray(mask["polygon"], dtype=float)
        if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3 or not np.all(np.isfinite(poly)):
            raise InputError("mask.polygon: expected at least 3 [u, v] points")
        return _resample_closed(poly, max_points)
    m = decode_rle(mask)
    if not m.any():
        raise InputError("mask: empty mask")
    pad = np.pad(m, 1)
    core = pad[1:-1, 1:-1]
    boundary = core & ~(pad[:-2, 1:-1] & pad[2:, 1:-1] & pad[1:-1, :-2] & pad[1:-1, 2:])
    v, u = np.nonzero(boundary)
    pts = np.stack([u + 0.5, v + 0.5], axis=1)
    # pixel centres lie half a pixel inside the outline: push them outwards from the centroid
    # centroid from the row and column sums (np.nonzero(m) would take 16 bytes per mask pixel)
    n_px = m.sum()
    c = np.array([m.sum(0) @ np.arange(m.shape[1]), m.sum(1) @ np.arange(m.shape[0])]) / n_px + 0.5
    d = pts - c
    n = np.linalg.norm(d, axis=1, keepdims=True)
    pts = pts + 0.5 * d / np.maximum(n, 1e-9)
    if len(pts) > max_points:
        ang = np.arctan2(d[:, 1], d[:, 0])
        order = np.argsort(ang)
        pts = pts[order[np.linspace(0, len(order) - 1, max_points).astype(int)]]
    return pts


def _resample_closed(poly: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    closed = np.vstack([poly, poly[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    t = np.linspace(0, s[-1], n, endpoint=False)
    return np.stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])], axis=1)
