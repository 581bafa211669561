"""The ``bayes`` pipeline as pure functions: search -> extract -> associate -> refine/bundle.

:func:`estimate` runs the stages over a frozen :class:`~.problem.Problem`:

1. :func:`.search.search` scores (cell, radius) hypotheses coarse to fine;
2. :func:`.extract.extract` takes objects greedily with look-ahead (explaining away);
3. :func:`.associate.swap_pass` and :func:`.associate.steal_pass` repair the association
   (config fields ``swap`` and ``steal``);
4. with a stated pose uncertainty, :func:`bundle` refines all objects jointly with a pose
   correction per view (:mod:`.bundle`);
5. :func:`.shapes.shape_stage` gives each object its shape (sphere, spheroid or ellipsoid);
6. :func:`.isolated.drop_isolated` drops weakly seen objects that lie apart in depth from every well-seen one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import InputError
from ...frames import invert_transform
from ...grid import VoxelGrid
from ...limits import MAX_BAYES_BOXES_PER_VIEW, MAX_BAYES_VIEWS
from ...result import DetectedObject
from .associate import steal_pass, swap_pass
from .bundle import bundle_adjust, correction_transform
from .extract import extract
from .isolated import drop_isolated
from .problem import Problem
from .refine import Observation
from .regroup import regroup_pass
from .search import search
from .second_look import second_look
from .shape_swap import shape_swap_pass
from .shapes import shape_stage
from .state import Found
from .view_assign import view_assignment
from .view_shift import view_shifts


@dataclass(frozen=True)
class Estimate:
    """What :func:`estimate` returns.

    Attributes
    ----------
    objects : list of DetectedObject, best score first
    pose_corrections : list of dict, per view with detections (empty unless a pose uncertainty is stated)
    timing_s : dict, seconds per stage
    diagnostics : dict, search statistics (see :meth:`.search.Hypotheses.stats`), ``isolated_dropped`` (objects
        :mod:`.isolated` dropped) and ``view_shifts`` (views whose boxes sit off together, :func:`.view_shift.view_shifts`;
        empty where a pose error is stated)
    """

    objects: list[DetectedObject]
    pose_corrections: list[dict[str, Any]] = field(default_factory=list)
    timing_s: dict[str, float] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)


def estimate(problem: Problem, grid: VoxelGrid | None) -> Estimate:
    """Objects in the problem's views (nothing without a grid or with fewer than ``min_views`` views)."""
    cfg = problem.config
    if grid is None or len(problem.views) < cfg.min_views:
        return Estimate([])
    check_work(problem)
    t0 = time.perf_counter()
    hyp = search(problem, grid)
    t1 = time.perf_counter()
    objects, taken = extract(problem, hyp)
    if cfg.tuning.swap:
        objects = swap_pass(problem, objects)
    if cfg.tuning.steal:
        objects, taken = steal_pass(problem, objects, taken, hyp)
    if cfg.tuning.regroup:
        objects, taken = regroup_pass(problem, objects, taken, hyp)
    t2 = time.perf_counter()
    timing = {"search_score": t1 - t0, "extract_refine": t2 - t1}
    corrections: list[dict[str, Any]] = []
    spheres = [o for o in objects if o.semi_up is None]
    if cfg.poses_uncertain and spheres:
        # the joint refinement models spheres; objects found as upright spheroids keep their own fit
        refined, corrections = bundle(problem, spheres)
        objects = refined + [o for o in objects if o.semi_up is not None]
        timing["bundle"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    objects = shape_stage(problem, objects)
    if cfg.tuning.shape_swap and cfg.shape == "auto":
        objects = shape_swap_pass(problem, objects)
    if cfg.tuning.second_look and cfg.shape == "auto":
        objects = second_look(problem, objects)
    if cfg.tuning.view_assign and cfg.shape == "auto":
        objects = view_assignment(problem, objects)
    timing["shape"] = time.perf_counter() - t3
    objects, dropped = drop_isolated(problem, objects)
    objects.sort(key=lambda o: -o.score)
    shifts = [] if cfg.poses_uncertain else view_shifts(problem, objects)
    diagnostics = {**hyp.stats(), "isolated_dropped": dropped, "view_shifts": shifts}
    return Estimate([o.as_result() for o in objects], corrections, timing, diagnostics)


def check_work(problem: Problem) -> None:
    """Refuse, before any work, a view with more boxes than :data:`~monovisual3d.limits.MAX_BAYES_BOXES_PER_VIEW`
    or more views with boxes than :data:`~monovisual3d.limits.MAX_BAYES_VIEWS`."""
    if len(problem.views) > MAX_BAYES_VIEWS:
        raise InputError(
            f"views: {len(problem.views):,} views with boxes, more than the {MAX_BAYES_VIEWS:,} the bayes search takes on "
            "(limits.MAX_BAYES_VIEWS); choose the views (e.g. every n-th) or split the session"
        )
    most = max((len(vd.boxes) for vd in problem.views), default=0)
    if most > MAX_BAYES_BOXES_PER_VIEW:
        v = max(problem.views, key=lambda vd: len(vd.boxes)).index
        raise InputError(
            f"views[{v}].detections: {most:,} boxes, more than the {MAX_BAYES_BOXES_PER_VIEW:,} per view the bayes search takes "
            "on (limits.MAX_BAYES_BOXES_PER_VIEW); thin the detections (e.g. a higher score threshold) or split the session"
        )


def bundle(problem: Problem, objects: list[Found]) -> tuple[list[Found], list[dict[str, Any]]]:
    """Refine all objects jointly with a pose correction per view (:mod:`.bundle`).

    Returns the objects (an object whose joint solution diverged keeps its own)
    and, per view with detections, its estimated pose correction: ``view``
    (index in the session), ``rotvec_optical_rad`` and ``translation_optical_m``
    (``p_optical_true = exp([rotvec]x) @ p_optical_reported + translation``),
    their posterior std ``std_rotvec_optical_rad`` and ``std_translation_optical_m``,
    and ``T_base_optical_corrected`` (4x4 nested lists).
    """
    cfg, views = problem.config, problem.views
    obs = [
        (i, v, Observation(vd.T_optical_base, vd.boxes[j], vd.contours[j] if cfg.use_masks else None))
        for i, o in enumerate(objects)
        for v, vd in enumerate(views)
        if (j := o.associations.get(vd.index, -1)) >= 0
    ]
    b = bundle_adjust(
        problem.camera,
        obs,
        np.stack([o.position for o in objects]),
        np.array([float(o.radius) for o in objects]),  # type: ignore[arg-type]
        problem.model,
        position_sigma=cfg.pose_position_sigma,
        rotation_sigma=cfg.pose_rotation_sigma,
        use_masks=cfg.use_masks,
        n_views=len(views),
    )
    out = []
    for i, o in enumerate(objects):
        lo, hi = cfg.fit_radius_range
        if not (np.all(np.isfinite(b.centres[i])) and lo <= b.radii[i] <= hi):
            out.append(o)  # keep the per-object solution rather than a diverged joint one
            continue
        learned = {**o.learned(), "radius_std": float(b.radius_std[i]), "pose_corrected": True}
        out.append(Found(b.centres[i], o.score, float(b.radii[i]), b.covariances[i], o.associations, o.n_cells, **learned))
    corrections = []
    for v, vd in enumerate(views):
        T_corrected = correction_transform(b.rotvec_optical[v], b.translation_optical[v]) @ vd.T_optical_base
        corrections.append(
            {
                "view": vd.index,
                "rotvec_optical_rad": b.rotvec_optical[v].tolist(),
                "translation_optical_m": b.translation_optical[v].tolist(),
                "std_rotvec_optical_rad": b.pose_std[v, :3].tolist(),
                "std_translation_optical_m": b.pose_std[v, 3:].tolist(),
                "T_base_optical_corrected": invert_transform(T_corrected).tolist(),
            }
        )
    return out, corrections
