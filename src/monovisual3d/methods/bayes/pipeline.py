"""The ``bayes`` method: one ordered list of passes over one state.

:data:`PASSES`, in order, each ``(problem, state) -> state`` (:class:`~.state.State`), run by :func:`estimate`:

1. ``search``: score sphere and spheroid hypotheses on the voxel grid, coarse to fine, ghosts explained away
2. ``extract``: take the best hypothesis as an object, refined, with its boxes; repeat with the boxes left
3. ``swap``: two objects that overlap in a view trade their boxes there where both fit better (switch ``tuning.swap``)
4. ``steal``: give an object back the box a neighbour took where the neighbour can do without it (switch
   ``tuning.steal``)
5. ``regroup``: extract again an object whose boxes are several fruit's, with its neighbours (switch
   ``tuning.regroup``; only where the search scored its last level)
6. ``poses``: refine the spheres jointly with a correction of each view's stated-uncertain pose (only where a pose
   uncertainty is stated)
7. ``shapes``: refit each object with the edges nearer objects cut left out, then fit its shape
8. ``shape_swap``: pairs side by side, one tall, trade boxes or are refitted where the shapes say so (switch
   ``tuning.shape_swap``; only where shape is auto)
9. ``second_look``: grow objects by, and build new ones from, the boxes no object holds (switch
   ``tuning.second_look``; only where shape is auto)
10. ``view_assign``: assign afresh one view's boxes around a free box to the objects there (switch
   ``tuning.view_assign``; only where shape is auto)
11. ``isolated``: drop weakly seen objects that lie apart in depth from the well-seen ones; best first
12. ``view_shifts``: name the views whose boxes all sit off the same way (a pose off) (only where no pose uncertainty
   is stated)
13. ``diagnose``: name a mistake every view shares (hand-eye, time offset, image size, distortion) from the pattern of
   the boxes' residuals (only where no pose uncertainty is stated)
14. ``quality``: every object's boxes against its fitted solid under the sensor model: chi-square, variance factors, an honest covariance, named causes

The problem (:class:`~.problem.Problem`: camera, options, the views with boxes, the region searched) stays fixed;
each pass reads the state the one before left and returns a new one. The passes share the helpers below them
(:mod:`.fits`, :mod:`.rays`, :mod:`.hypotheses`, :mod:`.occlusion`, :mod:`.scoring`), never each other.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ...errors import InputError
from ...limits import MAX_BAYES_BOXES_PER_VIEW, MAX_BAYES_VIEWS
from ...result import DetectedObject
from ...verdict import Cause
from . import (
    diagnose,
    extract,
    isolated,
    poses,
    quality,
    regroup,
    search,
    second_look,
    shape_swap,
    shapes,
    steal,
    swap,
    view_assign,
    view_shift,
)
from .problem import Problem
from .state import State


@dataclass(frozen=True)
class Condition:
    """Where a pass runs: ``holds(problem, state)``, and a short ``label`` the docs print."""

    label: str
    holds: Callable[[Problem, State], bool]


#: The moves judged with every model of the shape stage need ``shape`` auto.
SHAPE_AUTO = Condition("shape is auto", lambda problem, state: problem.config.shape == "auto")
#: The regroup reads every hypothesis of the last level, which the search leaves to the extraction in a dense scene.
LAST_LEVEL_SEARCHED = Condition(
    "the search scored its last level",
    lambda problem, state: state.hypotheses is not None and state.hypotheses.child_cell is None,
)
#: A pose uncertainty is stated (``pose_sigma_mm``, ``pose_sigma_deg``): the poses are refined.
POSES_UNCERTAIN = Condition("a pose uncertainty is stated", lambda problem, state: problem.config.poses_uncertain)
#: No pose uncertainty is stated: a view whose boxes sit off together says that its pose is off.
POSES_EXACT = Condition("no pose uncertainty is stated", lambda problem, state: not problem.config.poses_uncertain)


@dataclass(frozen=True)
class Pass:
    """One pass of the method.

    Attributes
    ----------
    name : str, also the key of its time in ``Result.timing_s``
    purpose : str, what it does, one line
    run : the pass, ``(problem, state) -> state``
    switch : str or None, the :class:`~.config.BayesTuning` field that turns it off (an ablation), None: none
    when : Condition or None, runs only where it holds (None: always)
    """

    name: str
    purpose: str
    run: Callable[[Problem, State], State]
    switch: str | None = None
    when: Condition | None = None

    def runs(self, problem: Problem, state: State) -> bool:
        """Whether the pass runs on this problem and state."""
        on = self.switch is None or bool(getattr(problem.config.tuning, self.switch))
        return on and (self.when is None or self.when.holds(problem, state))


#: The method, in order.
PASSES: tuple[Pass, ...] = (
    Pass("search", "score sphere and spheroid hypotheses on the voxel grid, coarse to fine, ghosts explained away", search.run),
    Pass("extract", "take the best hypothesis as an object, refined, with its boxes; repeat with the boxes left", extract.run),
    Pass("swap", "two objects that overlap in a view trade their boxes there where both fit better", swap.run, "swap"),
    Pass("steal", "give an object back the box a neighbour took where the neighbour can do without it", steal.run, "steal"),
    Pass(
        "regroup",
        "extract again an object whose boxes are several fruit's, with its neighbours",
        regroup.run,
        "regroup",
        LAST_LEVEL_SEARCHED,
    ),
    Pass(
        "poses",
        "refine the spheres jointly with a correction of each view's stated-uncertain pose",
        poses.run,
        None,
        POSES_UNCERTAIN,
    ),
    Pass("shapes", "refit each object with the edges nearer objects cut left out, then fit its shape", shapes.run),
    Pass(
        "shape_swap",
        "pairs side by side, one tall, trade boxes or are refitted where the shapes say so",
        shape_swap.run,
        "shape_swap",
        SHAPE_AUTO,
    ),
    Pass(
        "second_look",
        "grow objects by, and build new ones from, the boxes no object holds",
        second_look.run,
        "second_look",
        SHAPE_AUTO,
    ),
    Pass(
        "view_assign",
        "assign afresh one view's boxes around a free box to the objects there",
        view_assign.run,
        "view_assign",
        SHAPE_AUTO,
    ),
    Pass("isolated", "drop weakly seen objects that lie apart in depth from the well-seen ones; best first", isolated.run),
    Pass("view_shifts", "name the views whose boxes all sit off the same way (a pose off)", view_shift.run, None, POSES_EXACT),
    Pass(
        "diagnose",
        "name a mistake every view shares (hand-eye, time offset, image size, distortion) from the pattern of the boxes' "
        "residuals",
        diagnose.run,
        None,
        POSES_EXACT,
    ),
    Pass(
        "quality",
        "every object's boxes against its fitted solid under the sensor model: chi-square, variance factors, an honest "
        "covariance, named causes",
        quality.run,
    ),
)


def describe_passes() -> str:
    """The passes as the module docstring lists them: one numbered line each, with its switch and condition."""
    lines = []
    for i, p in enumerate(PASSES, 1):
        notes = ([f"switch ``tuning.{p.switch}``"] if p.switch else []) + ([f"only where {p.when.label}"] if p.when else [])
        lines.append(f"{i}. ``{p.name}``: {p.purpose}" + (f" ({'; '.join(notes)})" if notes else ""))
    return "\n".join(lines)


@dataclass(frozen=True)
class Estimate:
    """What :func:`estimate` returns.

    Attributes
    ----------
    objects : list of DetectedObject, best score first
    pose_corrections : list of dict, per view with detections (empty unless a pose uncertainty is stated)
    timing_s : dict, seconds per pass (by its name)
    diagnostics : dict, search statistics (see :meth:`.state.Hypotheses.stats`), ``isolated_dropped`` (objects
        :mod:`.isolated` dropped) and ``view_shifts`` (views whose boxes sit off together, :func:`.view_shift.view_shifts`;
        empty where a pose error is stated)
    quality : dict, the session's consistency (:meth:`.quality.Quality.to_dict`: variance factors, per object and per
        view), empty without an object
    causes : tuple of Cause, what the passes found wrong (:class:`~monovisual3d.verdict.Cause`)
    warnings : list of str, set by the front end (:class:`.localizer.BayesLocalizer`): the session's warnings, the
        causes' messages among them
    """

    objects: list[DetectedObject]
    pose_corrections: list[dict[str, Any]] = field(default_factory=list)
    timing_s: dict[str, float] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)
    quality: dict[str, Any] = field(default_factory=dict)
    causes: tuple[Cause, ...] = ()
    warnings: list[str] = field(default_factory=list)


def estimate(problem: Problem) -> Estimate:
    """Objects in the problem's views: :data:`PASSES` in order (nothing without a region or with fewer than
    ``min_views`` views)."""
    if problem.region is None or len(problem.views) < problem.config.min_views:
        return Estimate([])
    check_work(problem)
    state, timing = State(), {}
    for p in PASSES:
        if p.runs(problem, state):
            t0 = time.perf_counter()
            state = p.run(problem, state)
            timing[p.name] = time.perf_counter() - t0
    assert state.hypotheses is not None
    diagnostics = {**state.hypotheses.stats(), "isolated_dropped": state.isolated_dropped, "view_shifts": list(state.view_shifts)}
    quality_block = state.quality.to_dict() if state.quality is not None else {}
    objects = [o.as_result() for o in state.objects]
    return Estimate(objects, list(state.pose_corrections), timing, diagnostics, quality_block, state.causes)


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
