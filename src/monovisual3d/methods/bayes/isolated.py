"""Weakly seen objects that lie apart in depth from every well-seen one: false-positive boxes triangulated.

Two boxes whose rays meet make an object, whatever they show. False-positive boxes (a leaf, a stem, a reflection), or
a fruit's box and a false one, meet somewhere along an epipolar line at any depth, and the sensor model values such a
crossing like a fruit seen twice (9-14 nats). Three boxes' rays rarely meet by chance. The objects of one scene lie
together: the fruit of a plant or a row, the objects on a table. An object that holds boxes in fewer than
:data:`WELL_SEEN_VIEWS` views and whose depth lies more than ``isolated_margin`` outside the depths of the well-seen
objects, in every view where it holds a box (along the rays that triangulate it), is dropped
(why: docs/decisions/bayes-isolated.md#isolated_margin); it takes at least
:data:`MIN_WELL_SEEN` well-seen objects to say where the scene lies. A real fruit seen only twice that far in front of
or behind the others (the next row, through a gap) is dropped too; the result's diagnostics count the objects
dropped (``isolated_dropped``).

Three rays do meet by chance now and then: two false boxes and a fruit's, the fruit then missed (its box taken) and
the matching pairing it with an estimate 0.1-0.45 m away. An object seen in exactly three views is dropped only
when it lies outside the depths of the other well-seen objects by more than ``isolated_margin`` and more than
:data:`SPREAD_FACTOR` times their depth range, in its views: farther from the scene than the scene is deep.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .problem import Problem
from .state import Found, State

#: Well-seen objects needed before the scene's depth range says anything.
MIN_WELL_SEEN = 3
#: Views an object must hold boxes in to be well seen: three rays through its boxes must meet, which two false boxes'
#: rays (or a fruit's and a false one's) do anywhere along an epipolar line, three rarely.
WELL_SEEN_VIEWS = 3
#: An object seen in exactly :data:`WELL_SEEN_VIEWS` views is judged against the other well-seen objects with a margin of
#: at least this many times their depth range in each view: three rays meeting is stronger evidence than two, and the
#: objects of a table top lie spread over its depth, where those of a plant lie close: the chance crossings lie farther
#: outside the others' range than the scene is deep, true objects of a table top within it
#: (why: docs/decisions/bayes-isolated.md#spread_factor).
SPREAD_FACTOR = 1.0


def depths_per_view(problem: Problem, objects: list[Found]) -> np.ndarray:
    """Depth (optical z, metres) of each object's centre in each of the problem's views, shape (objects, views)."""
    p = np.array([o.position for o in objects], dtype=float).reshape(-1, 3)
    T = np.stack([vd.T_optical_base for vd in problem.views])  # (V, 4, 4)
    return np.einsum("vj,nj->nv", T[:, 2, :3], p) + T[:, 2, 3]


def isolated_in_depth(problem: Problem, objects: list[Found]) -> np.ndarray:
    """Which objects lie apart in depth from the well-seen ones, shape (objects,), bool.

    An object seen in fewer than :data:`WELL_SEEN_VIEWS` views is flagged when it lies more than ``isolated_margin``
    outside the depths of the well-seen objects in every view where it holds a box; one seen in exactly
    :data:`WELL_SEEN_VIEWS` views when it lies outside the depths of the other well-seen objects, in its views, by more
    than ``isolated_margin`` and more than :data:`SPREAD_FACTOR` times their depth range there. Objects seen in more
    views are kept.
    """
    cfg = problem.config
    out = np.zeros(len(objects), dtype=bool)
    if not objects or not problem.views:
        return out
    n_views = np.array([len(o.associations) for o in objects])
    well = n_views >= WELL_SEEN_VIEWS
    depth = depths_per_view(problem, objects)
    for i in np.flatnonzero(n_views <= WELL_SEEN_VIEWS):
        others = well & (np.arange(len(objects)) != i)
        if others.sum() < MIN_WELL_SEEN:
            continue
        lo, hi = depth[others].min(axis=0), depth[others].max(axis=0)
        margin = (
            cfg.isolated_margin if n_views[i] < WELL_SEEN_VIEWS else np.maximum(cfg.isolated_margin, SPREAD_FACTOR * (hi - lo))
        )
        own = np.array([vd.index in objects[i].associations for vd in problem.views])
        out[i] = bool(np.all(((depth[i] < lo - margin) | (depth[i] > hi + margin))[own]))
    return out


def drop_isolated(problem: Problem, objects: list[Found]) -> tuple[list[Found], int]:
    """``objects`` without those :func:`isolated_in_depth` flags, and how many were dropped."""
    flags = isolated_in_depth(problem, objects)
    return [o for o, f in zip(objects, flags) if not f], int(flags.sum())


def run(problem: Problem, state: State) -> State:
    """The pass: the objects without those :func:`isolated_in_depth` flags, best score first, and how many were
    dropped."""
    objects, dropped = drop_isolated(problem, list(state.objects))
    objects.sort(key=lambda o: -o.score)
    return replace(state.with_objects(objects), isolated_dropped=dropped)
