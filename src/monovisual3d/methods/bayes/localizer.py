"""The ``bayes`` method's front ends: :class:`BayesLocalizer` (incremental) and :func:`run` (one session)."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import replace

from ...camera import Camera
from ...completeness import incomplete_reasons
from ...errors import InputWarning
from ...grid import VoxelGrid
from ...result import DetectedObject, Result
from ...session import Session, View, Workspace
from ...session.diagnose import check_session
from ...verdict import with_causes
from . import edge_noise
from .config import BayesConfig
from .pipeline import Estimate, estimate
from .problem import build_problem
from .view_shift import shift_message

#: ``max_bytes`` of the region grid, which is only a description (nothing is allocated): 10**40 bytes, beyond any
#: memory, so no limit here; the search bounds its own memory (``max_memory``) when it allocates levels.
_DESCRIPTION_ONLY_BYTES = 10**40


def region_grid(config: BayesConfig, workspace: Workspace | None, first_view: View) -> VoxelGrid:
    """The region searched: the workspace, else the paper's cube in front of ``first_view``, at ``search_start``.

    Only a description (nothing is allocated): the search picks a coarser first level if it is too large.
    """
    if workspace is not None:
        return VoxelGrid.from_bounds(workspace.min, workspace.max, config.search_start, max_bytes=_DESCRIPTION_ONLY_BYTES)
    return VoxelGrid.in_front_of_camera(
        first_view.T_base_optical, config.search_start, config.reach, max_bytes=_DESCRIPTION_ONLY_BYTES
    )


class BayesLocalizer:
    """Stateful front end of the ``bayes`` method for incremental use (the filterpy shape).

    Call :meth:`update` as views arrive and :meth:`estimate` whenever estimates
    are needed: it runs :func:`.pipeline.estimate` over all views so far
    (milliseconds to a fraction of a second; twice that where the boxes scatter well beyond the sensor model and the
    session is localised again with their noise, :mod:`.edge_noise`, which as views arrive may start or stop and move
    the estimates by their noise).

    Parameters
    ----------
    camera : Camera
    config : BayesConfig
    workspace : Workspace, optional; else the paper's cube in front of the first view with a detection
    check_input : bool, run :func:`~monovisual3d.session.diagnose.check_session` on the views at each
        :meth:`estimate` (views given twice counted once; the causes among ``last.warnings`` and ``last.quality``), as
        :func:`monovisual3d.localize` does; False where the caller has checked them already
    warmup : bool, compile (first run) or load the compiled kernels now, with one estimate of the built-in example
        (:func:`warm_up`), so that the first :meth:`estimate` does not pay for it: a robot before its first view

    Attributes
    ----------
    views : list of View, the views so far
    grid : VoxelGrid or None, the region searched (set at the first view with a detection)
    last : Estimate or None, the last :meth:`estimate`'s full output (pose corrections, timings, diagnostics), with
        ``warnings`` (list of str, each also raised as an :class:`~monovisual3d.errors.InputWarning`) and ``quality``
        (the verdict, its causes, the residuals per object and per view: ``Result.quality``), as
        :func:`monovisual3d.localize` reports them

    Examples
    --------
    >>> from monovisual3d import load_session
    >>> from monovisual3d.examples import example_session_path
    >>> s = load_session(example_session_path())
    >>> loc = BayesLocalizer(s.camera)
    >>> for view in s.views:
    ...     loc.update(view)
    >>> len(loc.estimate())
    1
    """

    def __init__(
        self,
        camera: Camera,
        config: BayesConfig | None = None,
        *,
        workspace: Workspace | None = None,
        check_input: bool = True,
        warmup: bool = False,
    ) -> None:
        if warmup:
            warm_up(config or BayesConfig())
        self.camera = camera
        self.check_input = check_input
        self.config = config or BayesConfig()
        self.workspace = workspace
        self.views: list[View] = []
        self.grid: VoxelGrid | None = None
        self.last: Estimate | None = None

    def update(self, view: View) -> None:
        """Add one view."""
        self.views.append(view)
        if self.grid is None and view.detections:
            self.grid = region_grid(self.config, self.workspace, view)

    def estimate(self) -> list[DetectedObject]:
        """Objects found in the views so far (see :mod:`.pipeline`); what is wrong with them is raised as
        :class:`~monovisual3d.errors.InputWarning` and kept in ``last.warnings`` and ``last.quality``."""
        views, input_causes = list(self.views), []
        if self.check_input and self.views:
            checked, input_causes = check_session(Session(self.camera, tuple(self.views), self.workspace))
            views = list(checked.views)
        problem = build_problem(self.camera, self.config, views, self.grid)
        # flagged: what the estimate itself shows, so that localize() (whose input checks run before the method) does
        # the same
        session = Session(self.camera, tuple(views))
        problem, found = edge_noise.adapt(
            problem, estimate(problem), estimate, lambda first: _flagged(session, self.config, first)
        )
        if self.config.calibrate == "hand-eye":
            from .calibration import calibrate_hand_eye

            raised = found.quality.get("edge_noise")
            found = calibrate_hand_eye(problem, found, estimate)
            if raised is not None:  # its estimates ran on the raised noise too
                found = replace(found, quality={**found.quality, "edge_noise": raised})
        calibration = found.diagnostics.get("calibration")
        head = {"verdict": "ok", "causes": [], **found.quality}
        if calibration is not None:
            head["calibration"] = calibration
        quality = with_causes(head, [*input_causes, *found.causes])
        messages = [c.message for c in input_causes]
        messages += [m for m in session_messages(self.camera, self.config, views, found) if m not in messages]
        messages += [c["message"] for c in quality["causes"] if c["message"] not in messages]
        if calibration is not None and not calibration["applied"] and calibration["reason"] not in messages:
            messages.append(calibration["reason"])
        self.last = replace(found, quality=quality, warnings=messages)
        for msg in messages:
            warnings.warn(InputWarning(msg), stacklevel=2)
        return list(self.last.objects)

    @property
    def pose_corrections(self) -> list[dict]:
        """The pose corrections of the last :meth:`estimate` (empty unless a pose uncertainty is configured)."""
        return list(self.last.pose_corrections) if self.last is not None else []


def session_messages(camera: Camera, config: BayesConfig, views: list[View], found: Estimate) -> list[str]:
    """The warnings of an estimate before its causes: too few views or no object, the views whose boxes sit off
    together, a capped search."""
    messages = _check_views(views, config, found.objects)
    focal = max(camera.fx, camera.fy)
    messages += [shift_message(shift, focal) for shift in found.diagnostics.get("view_shifts", [])]
    if found.diagnostics.get("capped"):
        messages.append(
            f"the search kept only the best hypotheses at some level to stay within max_memory={config.max_memory:,} bytes "
            f"and max_hypotheses={config.tuning.max_hypotheses:,}; a smaller workspace or a coarser resolution searches exhaustively"
        )
    return messages


def _flagged(session: Session, config: BayesConfig, found: Estimate) -> bool:
    """Whether an estimate says something is wrong before its causes: a warning of :func:`session_messages`, or boxes
    left that ``--strict``'s completeness check reports (:func:`~monovisual3d.completeness.incomplete_reasons`)."""
    if session_messages(session.camera, config, list(session.views), found):
        return True
    result = Result(objects=list(found.objects), method="bayes", quality=dict(found.quality))
    return bool(incomplete_reasons(session, result))


def warm_up(config: BayesConfig | None = None) -> float:
    """One estimate of the built-in example session with ``config``, so that the compiled kernels are ready (compiled
    on a first run, loaded from the on-disk cache later); seconds taken.

    Examples
    --------
    >>> warm_up() < 600
    True
    """
    from ...examples import example_session_path
    from ...session.load import load_session

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = load_session(example_session_path())
        loc = BayesLocalizer(session.camera, config)
        for view in session.views:
            loc.update(view)
        loc.estimate()
    return time.perf_counter() - t0


def _check_views(views: list[View], config: BayesConfig, objects: list[DetectedObject]) -> list[str]:
    """Warnings for sessions that cannot give objects."""
    n_with = sum(1 for v in views if v.detections)
    messages = []
    if n_with < config.min_views:
        messages.append(f"only {n_with} view(s) have detections; at least {config.min_views} are needed to localise anything")
    elif not objects:
        pose_hint = (
            ""
            if config.poses_uncertain
            else "; if the poses may be off by several millimetres or tenths of a degree, state it (pose_sigma_mm, "
            "pose_sigma_deg; CLI --pose-sigma-mm, --pose-sigma-deg)"
        )
        messages.append(
            f"{n_with} views have detections but no object is consistent across them; check that positions are metres, "
            "quaternions are (x, y, z, w), pose_frame is right, and that the views look at the same fruit"
            f"{pose_hint} (objects scoring below accept={config.accept:g} nats are not reported)"
        )
    return messages


def run(session: Session, config: BayesConfig, *, progress: Callable[[int, int], None] | None = None) -> Result:
    """The ``bayes`` method on one session (see :mod:`monovisual3d.methods.bayes`)."""
    t0 = time.perf_counter()
    loc = BayesLocalizer(session.camera, config, workspace=session.workspace, check_input=False)  # localize() checked
    for i, view in enumerate(session.views):
        loc.update(view)
        if progress is not None:
            progress(i + 1, len(session.views))
    objects = loc.estimate()  # raises the warnings
    assert loc.last is not None
    grid = loc.grid.to_dict() if loc.grid is not None else {}
    return Result(
        objects=objects,
        method="bayes",
        grid=grid,
        timing_s={**loc.last.timing_s, "total": time.perf_counter() - t0},
        config=config.to_dict(),
        warnings=list(loc.last.warnings),
        diagnostics=dict(loc.last.diagnostics),
        pose_corrections=list(loc.last.pose_corrections),
        quality=dict(loc.last.quality),
    )
