"""Next-best-view planning: rank candidate camera poses by the expected gain of a view there.

Its parts: :mod:`.config` (the options), :mod:`.information` (box Jacobians, Fisher information,
occlusion by known fruit, what a camera sees), :mod:`.targets` (the state, objects and tentative
objects with their information so far); this module scores candidates and picks them.

The planner predicts, from the current estimate only (no new posterior per candidate):

**information**
    Every estimated object ``i`` (centre ``c``, radius ``r``) has an information matrix
    ``L_i`` (4 x 4 over ``(c, r)``) rebuilt from the views it was associated in: the Fisher
    information ``J^T W J`` of its four predicted box edges under the ``bayes`` sensor model
    (edge noise ``sigma = alpha * size + sigma0_px``, :mod:`monovisual3d.methods.bayes.sensor`),
    leaving out the edges the observed box shows occluded (inside the prediction by more than
    ``occluded_edge_sigma``) or cut by the image border. A candidate adds ``J^T W J`` of its
    own predicted box, each edge weighted by its visibility. The gain of object ``i`` is the
    expected drop of its RMS position error ``s = sqrt(trace of the position block of L^-1)``,
    in millimetres, capped at ``cap_mm`` (an object known worse than that counts as not localised).
**visibility**
    Per candidate and object: in front of the camera and inside the image (edges cut by
    the border carry nothing), occlusion by nearer estimated fruit (sample points of the
    predicted disc covered by nearer discs; an edge carries what its points show; below
    ``min_visible_fraction`` of the disc, no detection is expected), and a prior probability
    ``p_occluder`` that an unknown occluder (a leaf) hides it, raised towards ``p_occluder_seen``
    for candidates whose viewing direction is close (``occluder_angle_deg``) to a past view in
    which the object was predicted visible but missed, or seen with occluded edges.
**discovery**
    A box no object explains (a fruit seen once, a fruit the others hide, a false positive) is
    a tentative object on the box's ray at the depth a fruit of ``prior_radius_m`` would have,
    with the information of that one view plus a radius prior: its gain is computed as for an
    object, times ``discovery_weight``. The workspace's volume seen by fewer than two views
    adds ``coverage_mm`` times the fraction of it a candidate would newly cover (this decides
    the first view of an empty session).
**motion**
    ``motion_weight * (distance + rotation_scale_m * angle)`` from the current pose
    (the last view's; in a batch, the previous pick's), subtracted from the gain (mm per metre).

Batch mode (``count=k``) is greedy on the joint information: after each pick the expected
information of that view is added to every object and the next view is ranked again.

Stopping rule: ``done`` when there are at least two views, every object's 95 % position
error ellipsoid has its largest semi-axis within ``target_mm``
and no box is unexplained. With ``joint_confidence`` (default) the 95 % is for all objects at
once: each ellipsoid is taken at the ``0.95 ** (1 / n)`` quantile (1.22 times larger for six).
The ellipsoid is the larger of the method's (scaled to the box noise) and the one of the planner's
own information, which counts nothing from edges seen occluded.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._structured import read_structured_file
from ..camera import camera_from_dict
from ..checks import is_int
from ..errors import InputError
from ..methods.bayes.sensor import box_edge_sigma_px
from ..result import DetectedObject, Result
from ..session import Session, Workspace
from ..session.load import load_session, workspace_from_dict
from .candidates import check_candidates
from .config import PlannerConfig
from .information import (
    CHI2_3_95,
    CONFIDENCE,
    border_weights,
    boxes_and_jacobians,
    ellipsoid95_mm,
    fisher,
    occlusion_by_known,
    rms_mm,
    sees,
)
from .targets import PlannerState, Targets, build_targets, default_workspace, estimate_box_noise


@dataclass(frozen=True)
class Plan:
    """The planner's answer.

    Attributes
    ----------
    indices : tuple of int, chosen candidates (index in the given list), in order
    poses : ndarray, shape (k, 4, 4), their ``T_base_optical``
    gains : tuple of float, expected gain of each pick when it was picked (mm)
    ranking : ndarray, shape (N,), int, candidates ordered by first-pick gain (ties: lower index first)
    scores : ndarray, shape (N,), float, first-pick gain of every candidate (-inf: unreachable)
    components : dict of ndarray (N,), first-pick ``information``, ``discovery``, ``coverage``, ``motion``
    done : bool, the stopping rule
    ellipsoid_mm : ndarray, shape (M,), largest 95 % semi-axis of each object now, millimetres
    unexplained : list of (view, detection), boxes no object explains
    target_gains : ndarray, shape (N, M + U), first-pick expected gain (mm) of every candidate for every
        object (M, in the order given) and every tentative object (U, one per unexplained box)
    timing_s : float, planning time (without the localisation)
    box_noise : float, the box noise (fraction of the box size) the plan used: stated, estimated
        (``box_noise="auto"``) or the sensor model's
    """

    indices: tuple[int, ...]
    poses: NDArray[np.float64]
    gains: tuple[float, ...]
    ranking: NDArray[np.intp]
    scores: NDArray[np.float64]
    components: dict[str, NDArray[np.float64]]
    done: bool
    ellipsoid_mm: NDArray[np.float64]
    unexplained: list[tuple[int, int]]
    target_gains: NDArray[np.float64]
    timing_s: float = 0.0
    box_noise: float = 0.05

    @property
    def index(self) -> int:
        """The first chosen candidate."""
        return self.indices[0]

    @property
    def gain(self) -> float:
        return self.gains[0]

    def to_dict(self, pose_frame: str = "optical") -> dict[str, Any]:
        """JSON-ready dict: ``index``, ``pose``, ``gain``, ``ranking``, ``done`` (+ lists for a batch)."""
        from .candidates import pose_to_dict

        ranking = [
            {"index": int(i), "gain": float(self.scores[i]) if np.isfinite(self.scores[i]) else None} for i in self.ranking
        ]
        out: dict[str, Any] = {
            "index": int(self.index),
            "pose": pose_to_dict(self.poses[0], pose_frame),
            "gain": float(self.gain),
            "ranking": ranking,
            "done": bool(self.done),
            "ellipsoid95_mm": [float(x) for x in self.ellipsoid_mm],
            "unexplained": [{"view": v, "detection": d} for v, d in self.unexplained],
            "box_noise": float(self.box_noise),
            "pose_frame": pose_frame,
        }
        if len(self.indices) > 1:
            out["indices"] = [int(i) for i in self.indices]
            out["poses"] = [pose_to_dict(T, pose_frame) for T in self.poses]
            out["gains"] = [float(g) for g in self.gains]
        return out


# ----------------------------------------------------------------------------- scoring
def _candidate_terms(
    state: PlannerState,
    cfg: PlannerConfig,
    tg: Targets,
    T_ob: NDArray[np.float64],
    cand_dirs_pos: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per candidate and target: expected Fisher information (N, M, 4, 4) and detection probability (N, M)."""
    cam = state.camera
    N, M = len(T_ob), len(tg.centres)
    if M == 0:
        return np.zeros((N, 0, 4, 4)), np.zeros((N, 0))
    boxes, J, vis, depth = boxes_and_jacobians(cam, T_ob, tg.centres, tg.radii)
    sig = box_edge_sigma_px(cfg.stated_sensor, boxes)
    edge_free, frac = occlusion_by_known(boxes, np.where(np.isnan(depth), np.inf, depth))
    w_edge = border_weights(boxes, cam, cfg.border_px) * edge_free
    seen = vis & (frac >= cfg.min_visible_fraction)
    # unknown occluders: a prior, raised near directions in which the target was hidden before
    p_occ = np.full((N, M), cfg.p_occluder)
    s = math.radians(cfg.occluder_angle_deg)
    for m, dirs in enumerate(tg.occluded_dirs):
        if len(dirs) == 0:
            continue
        to_cam = cand_dirs_pos - tg.centres[m]
        to_cam /= np.linalg.norm(to_cam, axis=1, keepdims=True)
        ang = np.arccos(np.clip(to_cam @ dirs.T, -1.0, 1.0))  # (N, K)
        near = np.exp(-0.5 * (ang / s) ** 2).max(axis=1)
        p_occ[:, m] = cfg.p_occluder + (cfg.p_occluder_seen - cfg.p_occluder) * near
    p_det = np.where(seen, 1.0 - p_occ, 0.0)
    F = fisher(J, sig, np.where(seen[..., None], w_edge, 0.0))
    return F, p_det


def _coverage_setup(state: PlannerState, cfg: PlannerConfig, workspace: Workspace) -> tuple[NDArray, NDArray]:
    """Workspace sample points (P, 3) and how many views so far see each (P,)."""
    n = cfg.coverage_points
    axes = [np.linspace(lo, hi, n) for lo, hi in zip(workspace.min, workspace.max)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    count = np.zeros(len(pts))
    for v in state.views:
        count += sees(state.camera, np.linalg.inv(v.T_base_optical)[None], pts)[0]
    return pts, count


def _motion(T_from: NDArray[np.float64] | None, T_cand: NDArray[np.float64], cfg: PlannerConfig) -> NDArray[np.float64]:
    """Motion cost (N,) from one pose to each candidate (0 without a current pose or with motion_weight 0)."""
    if T_from is None or cfg.motion_weight == 0:
        return np.zeros(len(T_cand))
    dist = np.linalg.norm(T_cand[:, :3, 3] - T_from[:3, 3], axis=1)
    Rrel = np.einsum("ji,njk->nik", T_from[:3, :3], T_cand[:, :3, :3])
    ang = np.arccos(np.clip((np.trace(Rrel, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0))
    return cfg.motion_weight * (dist + cfg.rotation_scale_m * ang)


def _ellipsoids(state: PlannerState, tg: Targets) -> NDArray[np.float64]:
    """Largest 95 % semi-axis per object, mm: the method's covariance (scaled to the stated box noise) or, when
    larger, the one of the planner's own information, which counts nothing from edges seen occluded (a box a
    leaf cuts says little, however exact the detector)."""
    out = []
    for o, k, info in zip(state.objects, tg.variance_ratio, tg.info):
        if o.covariance is None:
            out.append(math.inf)
            continue
        own = np.linalg.inv(info)[:3, :3]
        out.append(max(ellipsoid95_mm(np.asarray(o.covariance) * k), ellipsoid95_mm(own)))
    return np.array(out)


def stop_scale(n_objects: int, cfg: PlannerConfig) -> float:
    """Factor on each 95 % ellipsoid's semi-axis in the stopping rule.

    With ``joint_confidence`` the 95 % holds for all ``n_objects`` fruit at once: each fruit's
    ellipsoid is taken at the ``0.95 ** (1 / n)`` quantile (Sidak), e.g. 1.22 times the 95 % one
    for six fruit; otherwise 1.

    Examples
    --------
    >>> round(stop_scale(6, PlannerConfig()), 3), stop_scale(6, PlannerConfig(joint_confidence=False))
    (1.223, 1.0)
    """
    if not cfg.joint_confidence or n_objects <= 1:
        return 1.0
    from scipy.stats import chi2

    return math.sqrt(float(chi2.ppf(CONFIDENCE ** (1.0 / n_objects), 3)) / CHI2_3_95)


#: Views a point needs to be triangulated: the coverage term and the stopping rule count to this.
MIN_VIEWS_TO_TRIANGULATE = 2
#: Sort key of an unreachable candidate in the ranking: below every finite gain.
_UNREACHABLE_KEY = -1e300


def plan_from_state(state: PlannerState, candidates: ArrayLike, *, count: int = 1, config: PlannerConfig | None = None) -> Plan:
    """Rank candidates for an explicit :class:`PlannerState` (see :func:`plan_next_view`)."""
    t0 = time.perf_counter()
    cfg = config or PlannerConfig()
    T_cand = check_candidates(candidates)
    N = len(T_cand)
    if not is_int(count) or count < 1:
        raise InputError(f"count: got {count!r}, expected a positive integer")
    reachable = np.linalg.norm(T_cand[:, :3, 3] - np.asarray(cfg.base_centre), axis=1) <= cfg.reach_m
    if count > int(reachable.sum()):
        raise InputError(f"count: got {count}, but only {int(reachable.sum())} of {N} candidates are reachable")
    workspace = default_workspace(state)
    if cfg.box_noise == "auto":
        estimated = estimate_box_noise(state, cfg)
        cfg = replace(cfg, box_noise=estimated)  # None (too few boxes yet): the sensor model's alpha
    tg = build_targets(state, cfg, workspace)
    picks = _greedy_picks(state, cfg, tg, T_cand, reachable, workspace, int(count))
    ranking = np.lexsort((np.arange(N), -np.where(np.isfinite(picks.first_scores), picks.first_scores, _UNREACHABLE_KEY)))
    ell = _ellipsoids(state, tg)
    unexplained = state.unexplained
    done = (
        len(state.views) >= MIN_VIEWS_TO_TRIANGULATE
        and not unexplained
        and bool(np.all(ell * stop_scale(len(ell), cfg) <= cfg.target_mm))
    )
    return Plan(
        indices=tuple(picks.picked),
        poses=T_cand[picks.picked],
        gains=tuple(picks.gains),
        ranking=ranking,
        scores=picks.first_scores,
        components=picks.components,
        done=done,
        ellipsoid_mm=ell,
        unexplained=unexplained,
        target_gains=picks.target_gains,
        timing_s=time.perf_counter() - t0,
        box_noise=cfg.stated_sensor.alpha,
    )


@dataclass
class _Picks:
    """The greedy batch: picked indices and gains, and the first pick's full scoring."""

    picked: list[int]
    gains: list[float]
    first_scores: NDArray[np.float64]  # (N,)
    components: dict[str, NDArray[np.float64]]  # each (N,)
    target_gains: NDArray[np.float64]  # (N, M)


def _greedy_picks(
    state: PlannerState,
    cfg: PlannerConfig,
    tg: Targets,
    T_cand: NDArray[np.float64],
    reachable: NDArray[np.bool_],
    workspace: Workspace,
    count: int,
) -> _Picks:
    """Pick ``count`` candidates one by one, adding each pick's expected information before ranking again."""
    T_ob = np.linalg.inv(T_cand)
    F, p_det = _candidate_terms(state, cfg, tg, T_ob, T_cand[:, :3, 3])
    pts, cov_count = _coverage_setup(state, cfg, workspace)
    seen = sees(state.camera, T_ob, pts)  # (N, P)
    info = tg.info.copy()
    current = state.views[-1].T_base_optical if state.views else None
    out = _Picks([], [], np.full(len(T_cand), -np.inf), {}, np.zeros((len(T_cand), len(tg.centres))))
    for step in range(count):
        s_now = np.minimum(rms_mm(info), cfg.cap_mm)  # (M,)
        s_new = np.minimum(rms_mm(info[None] + F), cfg.cap_mm)  # (N, M)
        per = p_det * (s_now[None] - s_new) * tg.weight[None]  # (N, M)
        obj_gain = per[:, : tg.n_objects].sum(axis=1)
        disc_gain = per[:, tg.n_objects :].sum(axis=1)
        need = np.clip(MIN_VIEWS_TO_TRIANGULATE - cov_count, 0, None)
        cov_gain = cfg.coverage_mm * (seen * need[None]).sum(axis=1) / max(MIN_VIEWS_TO_TRIANGULATE * len(pts), 1.0)
        motion = _motion(current, T_cand, cfg)
        total = np.where(reachable, obj_gain + disc_gain + cov_gain - motion, -np.inf)
        if out.picked:
            total[out.picked] = -np.inf
        if step == 0:
            out.first_scores = total.copy()
            out.components = {"information": obj_gain, "discovery": disc_gain, "coverage": cov_gain, "motion": motion}
            out.target_gains = per
        best = int(np.argmax(total))  # first maximum: ties go to the lower index
        out.picked.append(best)
        out.gains.append(float(total[best]))
        info = info + p_det[best][:, None, None] * F[best]
        cov_count = cov_count + seen[best]
        current = T_cand[best]
    return out


def load_planning_session(source: str | Path | dict[str, Any] | Session) -> Session:
    """:func:`monovisual3d.load_session`, also accepting a session with no views yet (``"views": []``).

    The planner needs only the camera and the workspace before the first view.
    """
    if isinstance(source, Session):
        return source
    data = read_structured_file(source) if isinstance(source, (str, Path)) else source
    if isinstance(data, dict) and data.get("views") == []:
        name = str(source) if isinstance(source, (str, Path)) else None
        try:
            camera = camera_from_dict(data.get("camera"))
            ws = workspace_from_dict(data["workspace"], "workspace") if data.get("workspace") is not None else None
        except InputError as exc:
            raise InputError(f"{name}: {exc}" if name else str(exc)) from None
        return Session(camera, (), ws, name)
    return load_session(data if not isinstance(source, (str, Path)) else source)


def plan_next_view(
    session_or_localizer: Any,
    candidates: ArrayLike,
    *,
    count: int = 1,
    objects: Result | list[DetectedObject] | None = None,
    workspace: Workspace | None = None,
    config: PlannerConfig | None = None,
    localize_options: dict[str, Any] | None = None,
    **options: Any,
) -> Plan:
    """Choose the next camera pose(s) from candidates by expected gain; report whether to stop.

    Parameters
    ----------
    session_or_localizer : Session, path, dict, or :class:`monovisual3d.methods.bayes.BayesLocalizer`
        The views so far. A session is localised with the ``bayes`` method (``localize_options``)
        unless ``objects`` is given; a localizer's :meth:`estimate` is used likewise.
    candidates : array_like, shape (N, 4, 4), ``T_base_optical`` of each candidate
        (see :mod:`monovisual3d.active.candidates` for files and caps)
    count : int, views to choose jointly (greedy on the joint information)
    objects : Result or list of DetectedObject, optional, the current estimate (avoids localising again)
    workspace : Workspace, optional, overrides the session's (default: a 0.4 m cube around the estimates)
    config : PlannerConfig, optional
    **options : fields of :class:`PlannerConfig` (e.g. ``motion_weight``, ``target_mm``, ``reach_m``)

    Returns
    -------
    Plan

    Examples
    --------
    >>> from monovisual3d.sim import paper_scene, simulate
    >>> from monovisual3d.active.candidates import CapSpec, cap_poses
    >>> session, _ = simulate(paper_scene(), rng=0)
    >>> plan = plan_next_view(session, cap_poses(CapSpec(n=20), [0.6, 0.0, 0.45]))
    >>> 0 <= plan.index < 20
    True
    """
    if config is not None and options:
        raise InputError("config and keyword options: give one or the other")
    try:
        cfg = config or PlannerConfig(**options)
    except TypeError as exc:
        raise InputError(f"plan_next_view: {exc}") from None
    camera, views, ws, objects = _views_and_estimate(session_or_localizer, objects, localize_options)
    objs = objects.objects if isinstance(objects, Result) else list(objects)
    state = PlannerState(camera, tuple(views), tuple(objs), workspace or ws)
    return plan_from_state(state, candidates, count=count, config=cfg)


def _views_and_estimate(
    session_or_localizer: Any, objects: Result | list[DetectedObject] | None, localize_options: dict[str, Any] | None
) -> tuple[Any, tuple[Any, ...], Workspace | None, Result | list[DetectedObject]]:
    """Camera, views, workspace and current estimate from a session (localised with ``bayes`` unless
    ``objects`` is given, and only with two views with boxes) or a ``BayesLocalizer``."""
    from ..methods.bayes import BayesLocalizer  # here, not at the top: the planner's import stays light

    if isinstance(session_or_localizer, BayesLocalizer):
        loc = session_or_localizer
        camera, views, ws = loc.camera, tuple(loc.views), loc.workspace
        if objects is None:
            objects = loc.estimate()
    else:
        if isinstance(session_or_localizer, (str, Path, dict, Session)):
            session = load_planning_session(session_or_localizer)
        else:
            raise InputError(
                f"session_or_localizer: expected a Session, path or BayesLocalizer, got {type(session_or_localizer).__name__}"
            )
        camera, views, ws = session.camera, session.views, session.workspace
        if objects is None:
            n_with = sum(1 for v in views if v.detections)
            if n_with >= MIN_VIEWS_TO_TRIANGULATE:
                from ..api import localize

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    objects = localize(session, method="bayes", **(localize_options or {}))
            else:
                objects = []
    return camera, tuple(views), ws, objects
