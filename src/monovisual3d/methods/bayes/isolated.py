"""Objects seen in two views that lie apart in depth from every well-seen one: false-positive boxes triangulated.

Two boxes whose rays meet make an object, whatever they show. False-positive boxes (a leaf, a stem, a reflection), or
a fruit's box and a false one, meet somewhere along an epipolar line at any depth, and the sensor model values such a
crossing like a fruit seen twice (9-14 nats). Three boxes' rays rarely meet by chance. The objects of one scene lie
together: the fruit of a plant or a row, the objects on a table. An object that holds boxes in fewer than
:data:`WELL_SEEN_VIEWS` views and whose depth lies more than ``isolated_margin`` outside the depths of the well-seen
objects, in every view, is dropped; it takes at least :data:`MIN_WELL_SEEN` well-seen objects to say where the scene
lies. A real fruit seen only twice that far in front of or behind the others (the next row, through a gap) is dropped
too; the result's diagnostics count the objects dropped (``isolated_dropped``).

Measured (``python benchmarks/option_ab.py accuracy greenhouse-clutter 6000 6200 -- isolated_margin=1e9``, the rule off
against the default): simulated greenhouse scenes with false-positive boxes, 200 seeds, RMS centre error of the matched
pairs 14.97 -> 11.05 mm, precision 0.981 -> 0.989, recall 0.983 unchanged; leaves alone (``greenhouse-noise 6000
6100``), the accuracy benchmark's other conditions, plant rows, table tops and Aldoma: unchanged.
"""

from __future__ import annotations

import numpy as np

from ...result import DetectedObject
from .problem import Problem

#: Well-seen objects needed before the scene's depth range says anything.
MIN_WELL_SEEN = 3
#: Views an object must hold boxes in to be well seen: three rays through its boxes must meet, which two false boxes'
#: rays (or a fruit's and a false one's) do anywhere along an epipolar line, three rarely.
WELL_SEEN_VIEWS = 3


def depths_per_view(problem: Problem, objects: list[DetectedObject]) -> np.ndarray:
    """Depth (optical z, metres) of each object's centre in each of the problem's views, shape (objects, views)."""
    p = np.array([o.position for o in objects], dtype=float).reshape(-1, 3)
    T = np.stack([vd.T_optical_base for vd in problem.views])  # (V, 4, 4)
    return np.einsum("vj,nj->nv", T[:, 2, :3], p) + T[:, 2, 3]


def isolated_in_depth(problem: Problem, objects: list[DetectedObject]) -> np.ndarray:
    """Which objects are seen in fewer than :data:`WELL_SEEN_VIEWS` views and lie more than ``isolated_margin`` outside
    the depths of the well-seen ones in every view, shape (objects,), bool."""
    cfg = problem.config
    out = np.zeros(len(objects), dtype=bool)
    if not objects or not problem.views:
        return out
    well = np.array([len(o.associations) >= WELL_SEEN_VIEWS for o in objects])
    if well.sum() < MIN_WELL_SEEN:
        return out
    depth = depths_per_view(problem, objects)
    lo = depth[well].min(axis=0) - cfg.isolated_margin
    hi = depth[well].max(axis=0) + cfg.isolated_margin
    return ~well & np.all((depth < lo) | (depth > hi), axis=1)


def drop_isolated(problem: Problem, objects: list[DetectedObject]) -> tuple[list[DetectedObject], int]:
    """``objects`` without those :func:`isolated_in_depth` flags, and how many were dropped."""
    flags = isolated_in_depth(problem, objects)
    return [o for o, f in zip(objects, flags) if not f], int(flags.sum())
