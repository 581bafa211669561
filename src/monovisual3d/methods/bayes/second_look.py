"""A second look at the boxes no object holds: objects the search had no hypothesis for, built from them.

The search scores spheres, upright spheroids and lying spheroids, the lying ones only in cells where two views have a
wide box. A lying object seen broadside (wide) in one view and end-on (tall, or square) in the others fits none of
these well: no hypothesis reaches ``accept``, or one takes its boxes of two close views and lands far off. Its boxes
are then left free, and the shape models, which fit a yawed ellipsoid to any three boxes, were never asked.

:func:`second_look` runs after the shape stage and its swap pass, wherever a view holds free boxes. It offers

- every object a free box in each view it has none in, where the rays through its box centres still meet
  (:func:`.shape_swap.centres_agree_many`), and
- every combination of free boxes in :data:`MIN_VIEWS` or more views whose centre rays meet, as a new object,

fits each with every model of the shape stage (:func:`.shapes.fitted_answer`) and values it under the sensor model
(:func:`.shapes.shape_value`: the box scores less the Bayesian information criterion's cost per parameter), each view
where the fitted object would be in the image without a box counting a miss (views without any detection are not in
the problem, as for the search), and every box it holds explained (not scored as a miss). A grown object is kept when
it beats the object refitted as it was by :data:`.shape_swap.MIN_GAIN_NATS` (a free box costs nothing as clutter; an
object whose own refit fails must be worth ``BayesConfig.accept``); a new one when it is worth ``accept``, as an
extracted object must be. The candidates with the most boxes are fitted first, and one whose boxes are a subset of a
kept one's is not fitted (it would leave a box free); the largest margins are taken first, and a box is taken once.
The kept objects' ``score`` is that value (nats).

Then an object seen in fewer than :data:`MIN_VIEWS` views may give its boxes up: the search can pair one object's box
in one view with another's in a second into one object seen twice (both triangulate from two views), leaving the two
objects' other boxes free. New objects built as above from its boxes and the free ones replace it when together they
are worth :data:`.shape_swap.MIN_GAIN_NATS` more than it (:func:`_released`).

Its cost is bounded: the combinations are screened for all at once (no more than :data:`MAX_SCREENED` in one pass),
and at most :data:`MAX_FITS` shape fits are made in all (every box of one or two lying objects left free in 3-14
views: 1-2 fits, 0.1-0.45 s). In plant rows of 12-96 fruit and every ``bench accuracy`` condition (false positives, leaf occlusion)
no combination passes the screen: free boxes there are false positives or fruit cut below ``accept``, whose box
centres do not meet.
``python benchmarks/tabletop_subsets.py 810 816`` measures it (lying objects, three views at random azimuths).
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
from numpy.typing import NDArray

from ...result import DetectedObject
from .problem import Problem
from .scoring import associations_list, boxes_of
from .shape_swap import MIN_GAIN_NATS, centres_agree_many, holding
from .shapes import Answer, fitted_answer, object_boxes, sensor_scores, shape_value, solid_boxes

#: Views a new object needs: the yawed ellipsoid of a lying object is fitted from three views (``shapes``).
MIN_VIEWS = 3
#: At most this many shape fits in one pass (each with every model of the shape stage: 10-50 ms for three views of
#: a table top, up to 0.5 s for ten views or more), the combinations with the most boxes first.
MAX_FITS = 16
#: At most this many combinations are screened in one pass (for all at once: about 0.3 s for 16,000); where more would
#: be (a cluttered scene, many views: they grow as the product of the views' free boxes), that part does not run.
MAX_SCREENED = 20_000


def free_boxes(problem: Problem, objects: list[DetectedObject]) -> list[NDArray[np.intp]]:
    """Per view of ``problem.views``, the indices of the boxes no object holds."""
    held = set().union(*(boxes_of(problem, o) for o in objects))
    return [
        np.array([j for j in range(len(vd.boxes)) if (v, j) not in held], dtype=np.intp) for v, vd in enumerate(problem.views)
    ]


def _misses(problem: Problem, answer: Answer, assoc: list[int]) -> float:
    """The sensor model's miss term (nats, negative) for each view without a box where the answer's predicted box
    lies in the image, in front of the camera."""
    empty = [v for v, j in enumerate(assoc) if j < 0]
    if not empty:
        return 0.0
    poses = np.array([np.linalg.inv(problem.views[v].T_optical_base) for v in empty])
    pred = solid_boxes(problem.camera, poses, answer[1], answer[0].extra.get("solid"))
    depth = np.array([problem.depth(v, answer[1].centre_base) for v in empty])
    size = np.array([problem.camera.width, problem.camera.height], dtype=float)
    inside = (depth > 0) & np.all(pred[:, 2:] > 0, axis=1) & np.all(pred[:, :2] < size, axis=1)
    return float(np.count_nonzero(inside)) * problem.model.miss_term


def _fitted_value(problem: Problem, seed: DetectedObject, assoc: list[int]) -> tuple[float, DetectedObject | None]:
    """``seed`` holding the boxes ``assoc`` (over ``problem.views``), fitted with every shape model, and its value
    (nats; -inf and None without a fit, or when the fit leaves a box it holds unexplained: a box scored as a miss is
    no part of the object)."""
    obj = holding(problem, seed, assoc)
    fit = fitted_answer(problem, obj)
    if fit is None:
        return -np.inf, None
    answer, n_edges = fit
    poses, boxes = object_boxes(problem, obj)
    if np.any(sensor_scores(problem, poses, boxes, answer[1], answer[0].extra.get("solid")) <= problem.model.miss_term):
        return -np.inf, None
    value = shape_value(problem, answer[0], answer, n_edges) + _misses(problem, answer, assoc)
    return value, answer[0]


@dataclasses.dataclass
class _Budget:
    """What the pass may still spend: combinations to screen, and shape fits (each with every model)."""

    screened: int = MAX_SCREENED
    fits: int = MAX_FITS

    def screen(self, n: float) -> bool:
        """Whether ``n`` more combinations may be screened (and count them)."""
        if n > self.screened:
            return False
        self.screened -= int(n)
        return True


def _fit(problem: Problem, budget: _Budget, seed: DetectedObject, assoc: list[int]) -> tuple[float, DetectedObject | None]:
    """:func:`_fitted_value` while the budget lasts (-inf and None after)."""
    if budget.fits <= 0:
        return -np.inf, None
    budget.fits -= 1
    return _fitted_value(problem, seed, assoc)


def _bar(problem: Problem, budget: _Budget, o: DetectedObject) -> float:
    """What ``o`` grown must be worth (nats): ``o`` refitted as it holds its boxes, judged as :func:`_fitted_value`
    judges a fit (so that it wins by its new box, not by the refit), and :data:`.shape_swap.MIN_GAIN_NATS` more; where
    that refit fails or leaves one of its boxes unexplained, ``accept``, as a new object."""
    value = _fit(problem, budget, o, associations_list(problem, o))[0]
    return value + MIN_GAIN_NATS if np.isfinite(value) else problem.config.accept


def _by_size(assocs: list[list[int]]) -> list[int]:
    """Order of associations with the most boxes first (a subset of a combination is a worse candidate: it leaves a
    box free and counts a miss there)."""
    return sorted(range(len(assocs)), key=lambda k: -sum(j >= 0 for j in assocs[k]))


def _within(i: int, assoc: list[int], kept: list[tuple[int, list[int]]]) -> bool:
    """Whether the boxes of candidate ``(i, assoc)`` are a subset of those of a kept candidate of the same object (or
    of a new object, ``i`` -1): it would leave a box of that one free, so it is not fitted."""
    return any(k == i and all(j < 0 or j == a[v] for v, j in enumerate(assoc)) for k, a in kept)


def _new_combinations(free: list[NDArray[np.intp]]) -> list[list[int]]:
    """Every association (over ``problem.views``, -1: none) of one free box or none per view, in :data:`MIN_VIEWS`
    views or more: the boxes a new object may hold."""
    options = [[-1, *f.tolist()] for f in free]
    return [list(a) for a in itertools.product(*options) if sum(j >= 0 for j in a) >= MIN_VIEWS]


def _candidates(problem: Problem, objects: list[DetectedObject], free: list[NDArray[np.intp]]) -> list[tuple[int, list[int]]]:
    """Associations to fit: ``(i, assoc)`` for object ``i`` grown by free boxes, ``(-1, assoc)`` for a new object of
    free boxes (in :data:`MIN_VIEWS` views or more); only those whose box-centre rays meet, the most boxes first."""
    out: list[tuple[int, list[int]]] = []
    for i, o in enumerate(objects):
        base = associations_list(problem, o)
        options = [[j] if j >= 0 else [-1, *free[v].tolist()] for v, j in enumerate(base)]
        out += [(i, list(a)) for a in itertools.product(*options) if list(a) != base]
    out += [(-1, a) for a in _new_combinations(free)]
    if not out:
        return out
    agree = centres_agree_many(problem, np.array([a for _, a in out], dtype=np.intp))
    kept = [c for c, ok in zip(out, agree) if ok]
    return [kept[k] for k in _by_size([a for _, a in kept])]


def second_look(problem: Problem, objects: list[DetectedObject]) -> list[DetectedObject]:
    """Grow objects by, and build new objects from, the boxes no object holds, then replace objects seen in fewer than
    :data:`MIN_VIEWS` views by new ones of their boxes and the free ones, where the shape models say so (the module
    docstring); at most :data:`MAX_FITS` shape fits in all."""
    budget = _Budget()
    return _released(problem, _grown_and_new(problem, objects, budget), budget)


def _grown_and_new(problem: Problem, objects: list[DetectedObject], budget: _Budget) -> list[DetectedObject]:
    """Objects grown by free boxes and new objects of free boxes (the module docstring); ``objects`` itself when no
    view holds free boxes or too many combinations would be screened."""
    free = free_boxes(problem, objects)
    with_free = sum(len(f) > 0 for f in free)
    if with_free == 0 or (with_free < MIN_VIEWS and not objects):
        return objects
    if not budget.screen(np.prod([len(f) + 1.0 for f in free]) * (len(objects) + 1)):
        return objects
    scored = []
    bars: dict[int, float] = {}
    for i, assoc in _candidates(problem, objects, free):
        if _within(i, assoc, [(k, a) for _, k, a, _, _ in scored]):
            continue
        if i >= 0 and i not in bars:
            bars[i] = _bar(problem, budget, objects[i])
        value, fitted = _fit(problem, budget, objects[i] if i >= 0 else _new_seed(), assoc)
        bar = bars[i] if i >= 0 else problem.config.accept
        if fitted is not None and value > bar:
            scored.append((value - bar, i, assoc, fitted, value))
    out = list(objects)
    taken: set[tuple[int, int]] = set()
    grown: set[int] = set()
    for _, i, assoc, fitted, value in sorted(scored, key=lambda s: -s[0]):
        new_boxes = {(v, j) for v, j in enumerate(assoc) if j >= 0 and (i < 0 or associations_list(problem, objects[i])[v] != j)}
        if new_boxes & taken or i in grown:
            continue
        taken |= new_boxes
        obj = dataclasses.replace(fitted, score=float(value))
        if i >= 0:
            out[i] = obj
            grown.add(i)
        else:
            out.append(obj)
    return out


def _released(problem: Problem, objects: list[DetectedObject], budget: _Budget) -> list[DetectedObject]:
    """Each object seen in fewer than :data:`MIN_VIEWS` views replaced by new objects of its boxes and the free ones
    (each worth ``accept``, in :data:`MIN_VIEWS` or more views, one of its boxes at least) when together they are worth
    :data:`.shape_swap.MIN_GAIN_NATS` more than it: a ghost of two objects' boxes in two views, whose other boxes
    were left free."""
    out = list(objects)
    for i in [i for i, o in enumerate(objects) if 0 < len(o.associations) < MIN_VIEWS]:
        free = free_boxes(problem, [o for k, o in enumerate(out) if k != i])
        own = associations_list(problem, out[i])
        if sum(len(f) > 0 for f in free) < MIN_VIEWS or not budget.screen(np.prod([len(f) + 1.0 for f in free])):
            continue
        combos = [a for a in _new_combinations(free) if any(j >= 0 and j == own[v] for v, j in enumerate(a))]
        if not combos:
            continue
        agree = centres_agree_many(problem, np.array(combos, dtype=np.intp))
        combos = [a for a, ok in zip(combos, agree) if ok]
        scored = []
        for assoc in [combos[k] for k in _by_size(combos)]:
            if _within(-1, assoc, [(-1, a) for _, a, _ in scored]):
                continue
            value, fitted = _fit(problem, budget, _new_seed(), assoc)
            if fitted is not None and value > problem.config.accept:
                scored.append((value, assoc, fitted))
        chosen, taken, total = [], set(), 0.0
        for value, assoc, fitted in sorted(scored, key=lambda c: -c[0]):
            boxes = {(v, j) for v, j in enumerate(assoc) if j >= 0}
            if not boxes & taken:
                chosen.append(dataclasses.replace(fitted, score=float(value)))
                taken |= boxes
                total += value
        if chosen and total > _fit(problem, budget, out[i], own)[0] + MIN_GAIN_NATS:
            out[i] = chosen[0]
            out += chosen[1:]
    return out


def _new_seed() -> DetectedObject:
    """A placeholder object for a combination of free boxes: the shape fits start from the boxes alone."""
    return DetectedObject(np.zeros(3), 0.0, None, None, {}, 0, {})
