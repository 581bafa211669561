"""Boxes from label images and box overlap (numpy only).

Boxes are ``bbox_xyxy`` in the project's continuous pixel coordinates: a region
covering pixel columns 10..19 has ``x1 = 10, x2 = 20`` (see :mod:`monovisual3d.camera`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import is_int
from ..errors import InputError


def boxes_from_label_image(
    labels: ArrayLike, count: int, *, min_pixels: int = 1
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Bounding box of the pixels of each label in a label image.

    Parameters
    ----------
    labels : array_like, shape (height, width), integer; values ``0 .. count - 1``
        are objects, anything else (e.g. -1) is background
    count : int, number of objects
    min_pixels : int, objects with fewer visible pixels get no box

    Returns
    -------
    boxes_xyxy : ndarray, shape (count, 4), float64, pixels; NaN rows for objects not seen
    pixels : ndarray, shape (count,), int64, visible pixels per object

    Examples
    --------
    >>> labels = np.full((4, 6), -1)
    >>> labels[1:3, 2:5] = 0
    >>> boxes_from_label_image(labels, 2)[0]
    array([[ 2.,  1.,  5.,  3.],
           [nan, nan, nan, nan]])
    """
    lab = np.asarray(labels)
    if lab.ndim != 2:
        raise InputError(f"labels: expected a (height, width) image, got shape {list(lab.shape)}")
    if not np.issubdtype(lab.dtype, np.integer):
        raise InputError(f"labels: expected integer labels, got dtype {lab.dtype}")
    if not is_int(count) or count < 0:
        raise InputError(f"count: expected a non-negative integer, got {count!r}")
    boxes = np.full((int(count), 4), np.nan)
    pixels = np.zeros(int(count), dtype=np.int64)
    valid = (lab >= 0) & (lab < count)
    v, u = np.nonzero(valid)
    k = lab[v, u].astype(np.intp)
    if k.size:
        pixels[:] = np.bincount(k, minlength=count)
        seen = pixels >= max(int(min_pixels), 1)
        x1 = np.full(count, np.iinfo(np.int64).max)
        y1 = np.full(count, np.iinfo(np.int64).max)
        x2 = np.full(count, -1)
        y2 = np.full(count, -1)
        np.minimum.at(x1, k, u)
        np.minimum.at(y1, k, v)
        np.maximum.at(x2, k, u + 1)
        np.maximum.at(y2, k, v + 1)
        boxes[seen] = np.stack([x1, y1, x2, y2], axis=-1)[seen]
    return boxes, pixels


def box_iou(boxes_a: ArrayLike, boxes_b: ArrayLike) -> NDArray[np.float64]:
    """Intersection over union of boxes, broadcasting over leading dimensions.

    Parameters
    ----------
    boxes_a, boxes_b : array_like, shape (..., 4), ``bbox_xyxy`` pixels

    Returns
    -------
    iou : ndarray, shape (...), in [0, 1]; NaN where a box is NaN

    Examples
    --------
    >>> float(box_iou([0, 0, 2, 2], [1, 0, 3, 2]))
    0.3333333333333333
    """
    a = np.asarray(boxes_a, dtype=float)
    b = np.asarray(boxes_b, dtype=float)
    if a.shape[-1:] != (4,) or b.shape[-1:] != (4,):
        raise InputError(f"boxes: expected shape (..., 4), got {list(a.shape)} and {list(b.shape)}")
    iw = np.clip(np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0]), 0, None)
    ih = np.clip(np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1]), 0, None)
    inter = iw * ih
    area_a = (a[..., 2] - a[..., 0]) * (a[..., 3] - a[..., 1])
    area_b = (b[..., 2] - b[..., 0]) * (b[..., 3] - b[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return inter / (area_a + area_b - inter)


def match_boxes(boxes_a: ArrayLike, boxes_b: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """Pair boxes of two sets one-to-one by maximum total IoU (Hungarian assignment).

    Parameters
    ----------
    boxes_a : array_like, shape (N, 4); boxes_b : array_like, shape (M, 4); NaN rows are never paired

    Returns
    -------
    index_a, index_b : ndarray, shape (K,), paired rows (pairs with IoU 0 are dropped)
    iou : ndarray, shape (K,)
    """
    from scipy.optimize import linear_sum_assignment

    a = np.asarray(boxes_a, dtype=float).reshape(-1, 4)
    b = np.asarray(boxes_b, dtype=float).reshape(-1, 4)
    iou = np.nan_to_num(box_iou(a[:, None, :], b[None, :, :]), nan=0.0)
    if iou.size == 0:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty, np.zeros(0)
    ia, ib = linear_sum_assignment(-iou)
    keep = iou[ia, ib] > 0
    return ia[keep], ib[keep], iou[ia, ib][keep]
