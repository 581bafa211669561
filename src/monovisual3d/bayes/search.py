"""Coarse-to-fine search of the cells that can hold an object.

A cell can hold an object only if, in at least ``min_views`` views, its
centre projects inside one of the boxes, widened by half the box size on
each side (room for partial occlusion) plus the cell's own projected
half-diagonal. Starting from a coarse grid over the workspace, surviving
cells are split into 8 children until the target resolution is reached, so
the cost grows with the volume of the viewing-cone intersections, not with
the workspace.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..frames import invert_transform, transform_points
from ..session import View

#: The eight child offsets of an octree split, in units of the child cell size.
_CHILD_OFFSETS = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (-0.5, 0.5)])


def cone_counts(
    camera: Camera, views: list[View], centres_base: NDArray[np.floating], half_diagonal: float, widen: float = 0.5
) -> NDArray[np.int32]:
    """In how many views each point projects inside a (widened) box.

    Parameters
    ----------
    camera : Camera
    views : list of View (views without detections count for nothing)
    centres_base : ndarray, shape (N, 3), metres, base frame
    half_diagonal : float, metres: radius of the region each point stands for
    widen : float, boxes are widened by this fraction of their size on each side

    Returns
    -------
    counts : ndarray, shape (N,), int32
    """
    counts = np.zeros(len(centres_base), dtype=np.int32)
    f = max(camera.fx, camera.fy)
    for view in views:
        boxes = view.boxes_xyxy
        if len(boxes) == 0:
            continue
        p_opt = transform_points(invert_transform(view.T_base_optical), centres_base)
        z = p_opt[:, 2]
        front = z > 1e-6
        uv = camera.project(p_opt)
        with np.errstate(divide="ignore", invalid="ignore"):
            margin = np.where(front, f * half_diagonal / np.maximum(z, 1e-6), np.inf) + 2.0
        inside = np.zeros(len(centres_base), dtype=bool)
        # a point whose region reaches behind the camera gets the benefit of the doubt
        near = (z > -half_diagonal) & ~front
        for x1, y1, x2, y2 in boxes:
            wx, wy = widen * (x2 - x1), widen * (y2 - y1)
            u, v = uv[:, 0], uv[:, 1]
            inside |= (u >= x1 - wx - margin) & (u <= x2 + wx + margin) & (v >= y1 - wy - margin) & (v <= y2 + wy + margin)
        counts += (inside | near).astype(np.int32)
    return counts


def split_cells(centres_grid: NDArray[np.floating], size: float) -> NDArray[np.float64]:
    """Octree split: the 8 children (cell size ``size / 2``) of each cell centre, shape (8N, 3).

    The children of input row ``i`` are output rows ``8 i`` to ``8 i + 7``.
    """
    child = size / 2
    return (centres_grid[:, None, :] + _CHILD_OFFSETS[None, :, :] * child).reshape(-1, 3)
