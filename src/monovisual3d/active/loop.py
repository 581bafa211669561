"""The closed loop in simulation: plan a view, render it with the simulator's camera, detect, update.

:func:`run_loop` plays one strategy on one scene for ``n_views`` views; the first view is
given (the paper's axial pose by default), the rest are chosen by the strategy:

- ``nbv``: :func:`~monovisual3d.active.planner.plan_next_view` on the candidates;
- ``random``: a random unused candidate (``rng``);
- ``sphere``: the view-sphere heuristic, the candidate whose smallest angle (seen from the
  workspace centre) to the views so far is largest;
- ``fixed``: a fixed sequence, not from the candidates: the paper's three poses, then the
  rest of a ring at the same angle (:func:`fixed_sequence`).

Detections come from the simulator (:func:`monovisual3d.sim.simulate.simulate_views`:
ray-cast bounding-box camera, then the noise model); the estimate after each view is the
``bayes`` method's (:class:`~monovisual3d.methods.bayes.BayesLocalizer`).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import is_int
from ..errors import InputError
from ..frames import look_at
from ..methods.bayes import BayesConfig, BayesLocalizer
from ..result import DetectedObject
from ..session import Detection, Session, View, Workspace
from ..sim.noise import NoiseModel
from ..sim.scene import Scene
from ..sim.simulate import DETECTION_LABEL, simulate_views
from ..sim.viewpoints import PAPER_OFFSET_M, paper_poses
from .config import PlannerConfig
from .planner import Plan, plan_from_state
from .targets import PlannerState

STRATEGIES = ("nbv", "fixed", "random", "sphere")
#: Half side of the planner's workspace cube around the scene's target in simulation, metres.
SIM_WORKSPACE_HALF_M = 0.2


@dataclass
class LoopStep:
    """One view of a loop: where it was taken and what the estimate was after it.

    Attributes
    ----------
    T_base_optical : ndarray, shape (4, 4), the true pose of the view
    candidate : int, index of the candidate chosen (-1: the first view or a fixed pose)
    objects : list of DetectedObject, the estimate after this view
    plan : Plan or None, the plan made after this view (``nbv`` only)
    plan_s : float, seconds spent planning the next view after this one
    """

    T_base_optical: NDArray[np.float64]
    candidate: int
    objects: list[DetectedObject]
    plan: Plan | None = None
    plan_s: float = 0.0


@dataclass
class LoopRun:
    """A whole loop: the session it recorded and the steps."""

    session: Session
    steps: list[LoopStep] = field(default_factory=list)

    @property
    def chosen(self) -> list[int]:
        return [s.candidate for s in self.steps]


def fixed_sequence(target: ArrayLike, n: int) -> NDArray[np.float64]:
    """The ``fixed`` baseline: the paper's three poses, then more poses on the same ring.

    The paper's poses 2 and 3 sit at 45 and 225 degrees (up-right, down-left) on a ring of
    half-angle ``atan(0.2 * sqrt(2) / 0.5)`` (29.5 degrees) around the axial view, 0.57 m from
    the target; the sequence continues at 135, 315, 0, 180, 90, 270 degrees on that ring.

    Returns
    -------
    T_base_optical : ndarray, shape (n, 4, 4)
    """
    t = np.asarray(target, dtype=float)
    P = paper_poses(t)
    if n <= 3:
        return P[:n]
    first = P[0]
    right, up = first[:3, 0], -first[:3, 1]
    cam0 = first[:3, 3]
    out = list(P)
    for az in (135.0, 315.0, 0.0, 180.0, 90.0, 270.0)[: n - 3]:
        a = math.radians(az)
        # same in-plane offset length as the paper's poses: offset * sqrt(2)
        shift = PAPER_OFFSET_M * math.sqrt(2) * (math.cos(a) * right + math.sin(a) * up)
        out.append(look_at(cam0 + shift, t))
    if n > len(out):
        raise InputError(f"fixed_sequence: at most {len(out)} poses, got n={n}")
    return np.stack(out)


def observe(
    scene: Scene,
    camera: Camera,
    T_base_optical: NDArray[np.float64],
    noise: NoiseModel,
    rng: np.random.Generator,
    E_hand_eye: NDArray[np.float64] | None = None,
) -> View:
    """Render one view and apply the noise model: the view a robot would record (reported pose, boxes).

    ``E_hand_eye`` (4, 4): the session's hand-eye error, drawn once with :meth:`NoiseModel.hand_eye_error` (as
    :func:`run_loop` does); None: one drawn from ``noise`` for this view alone."""
    sv = simulate_views(scene, camera, T_base_optical[None], noise=noise, rng=rng, E_hand_eye=E_hand_eye)[0]
    dets = tuple(Detection(np.asarray(b, dtype=float), None, DETECTION_LABEL) for b in sv.boxes_xyxy)
    return View(sv.T_base_optical_reported, dets)


def sphere_pick(T_views: list[NDArray[np.float64]], candidates: NDArray[np.float64], centre: ArrayLike, used: set[int]) -> int:
    """View-sphere heuristic: the unused candidate with the largest smallest angle to the views so far (seen from ``centre``)."""
    c = np.asarray(centre, dtype=float)
    d_c = candidates[:, :3, 3] - c
    d_c /= np.linalg.norm(d_c, axis=1, keepdims=True)
    d_v = np.stack([T[:3, 3] for T in T_views]) - c
    d_v /= np.linalg.norm(d_v, axis=1, keepdims=True)
    ang = np.arccos(np.clip(d_c @ d_v.T, -1, 1)).min(axis=1)
    ang[list(used)] = -np.inf
    return int(np.argmax(ang))


def run_loop(
    scene: Scene,
    camera: Camera,
    candidates: NDArray[np.float64],
    n_views: int,
    *,
    strategy: str = "nbv",
    target: ArrayLike,
    first_pose: NDArray[np.float64] | None = None,
    noise: NoiseModel | None = None,
    rng: np.random.Generator | int | None = None,
    choice_rng: np.random.Generator | int | None = None,
    planner: PlannerConfig | None = None,
    bayes: BayesConfig | None = None,
    stop: bool = False,
) -> LoopRun:
    """Play one strategy for ``n_views`` views (see the module docstring).

    Parameters
    ----------
    scene : Scene
    camera : Camera
    candidates : ndarray, shape (N, 4, 4), true ``T_base_optical`` of each candidate
    n_views : int, views in all, the first included
    strategy : str, one of :data:`STRATEGIES`
    target : array_like, shape (3,), the workspace centre (the cap's target), metres, base frame
    first_pose : ndarray (4, 4), default the paper's axial pose at ``target``
    noise : NoiseModel, default none
    rng : seed of the detection noise (the same seed gives every strategy the same first view)
    choice_rng : seed of the ``random`` strategy
    planner : PlannerConfig for ``nbv``
    bayes : BayesConfig of the localizer
    stop : bool, stop as soon as the plan says ``done`` (``nbv`` only)

    Returns
    -------
    LoopRun
    """
    if strategy not in STRATEGIES:
        raise InputError(f"strategy: got {strategy!r}, expected one of {', '.join(STRATEGIES)}")
    if not is_int(n_views) or n_views < 1:
        raise InputError(f"n_views: got {n_views!r}, expected a positive integer")
    t = np.asarray(target, dtype=float)
    noise = noise or NoiseModel()
    rng = np.random.default_rng(rng)
    E_hand_eye = noise.hand_eye_error(rng)  # the session's, the same in every view
    chooser = _Chooser(strategy, candidates, t, planner or PlannerConfig(), np.random.default_rng(choice_rng), n_views, stop)
    T_next = paper_poses(t)[0] if first_pose is None else np.asarray(first_pose, dtype=float)
    loc = BayesLocalizer(camera, bayes or BayesConfig())
    steps: list[LoopStep] = []
    cand_index = -1
    for k in range(n_views):
        steps.append(_observe_step(loc, scene, camera, T_next, cand_index, noise, rng, E_hand_eye))
        chosen = chooser.next_view(steps, loc, last=k + 1 >= n_views)
        if chosen is None:
            break
        T_next, cand_index = chosen
    return LoopRun(Session(camera, tuple(loc.views)), steps)


@dataclass
class _Chooser:
    """One strategy's choice of the view after each step (see the module docstring).

    Attributes
    ----------
    strategy : str, one of :data:`STRATEGIES`
    candidates : ndarray, shape (N, 4, 4), true ``T_base_optical`` of each candidate
    target : ndarray, shape (3,), the workspace centre, metres, base frame
    planner : PlannerConfig, its reach also limits the ``random`` and ``sphere`` picks
    choice_rng : Generator of the ``random`` strategy
    n_views : int, views in all, the first included
    stop : bool, ``nbv`` stops as soon as the plan says ``done``
    used : set of int, the candidates taken so far
    workspace : Workspace, the planner's: a cube of half side :data:`SIM_WORKSPACE_HALF_M` around ``target``
    fixed : ndarray, shape (n_views, 4, 4), the ``fixed`` sequence, or None
    """

    strategy: str
    candidates: NDArray[np.float64]
    target: NDArray[np.float64]
    planner: PlannerConfig
    choice_rng: np.random.Generator
    n_views: int
    stop: bool
    used: set[int] = field(default_factory=set)
    workspace: Workspace = field(init=False)
    fixed: NDArray[np.float64] | None = field(init=False)

    def __post_init__(self) -> None:
        self.workspace = Workspace(self.target - SIM_WORKSPACE_HALF_M, self.target + SIM_WORKSPACE_HALF_M)
        self.fixed = fixed_sequence(self.target, self.n_views) if self.strategy == "fixed" else None

    @property
    def reachable(self) -> NDArray[np.bool_]:
        """Candidates within the arm's reach, shape (N,)."""
        base = np.asarray(self.planner.base_centre)
        return np.linalg.norm(self.candidates[:, :3, 3] - base, axis=1) <= self.planner.reach_m

    def next_view(self, steps: list[LoopStep], loc: BayesLocalizer, *, last: bool) -> tuple[NDArray[np.float64], int] | None:
        """The pose and candidate index (-1: not a candidate) of the view after ``steps``; None to stop.

        ``nbv`` plans after every view, the last included, and keeps the plan in the step.
        """
        if self.strategy == "nbv":
            plan, free_idx = _plan_step(steps[-1], loc, loc.camera, self.workspace, self.candidates, self.used, self.planner)
            if last or (self.stop and plan.done):
                return None
            index = int(free_idx[plan.index])
        elif last:
            return None
        elif self.strategy == "fixed":
            assert self.fixed is not None
            return self.fixed[len(steps)], -1
        elif self.strategy == "random":
            reachable = self.reachable
            free = [i for i in range(len(self.candidates)) if i not in self.used and reachable[i]]
            index = int(self.choice_rng.choice(free))
        else:
            blocked = set(self.used) | set(np.flatnonzero(~self.reachable).tolist())
            index = sphere_pick([s.T_base_optical for s in steps], self.candidates, self.target, blocked)
        self.used.add(index)
        return self.candidates[index], index


def _observe_step(
    loc: BayesLocalizer,
    scene: Scene,
    camera: Camera,
    T_base_optical: NDArray[np.float64],
    cand_index: int,
    noise: NoiseModel,
    rng: np.random.Generator,
    E_hand_eye: NDArray[np.float64] | None,
) -> LoopStep:
    """Take the view at ``T_base_optical`` (with the session's hand-eye error ``E_hand_eye``), update the localizer,
    return the step with its estimate."""
    view = observe(scene, camera, T_base_optical, noise, rng, E_hand_eye)
    loc.update(view)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        objects = loc.estimate()
    return LoopStep(T_base_optical, cand_index, objects)


def _plan_step(
    step: LoopStep,
    loc: BayesLocalizer,
    camera: Camera,
    workspace: Workspace,
    candidates: NDArray[np.float64],
    used: set[int],
    cfg: PlannerConfig,
) -> tuple[Plan, NDArray[np.intp]]:
    """``nbv``: plan over the unused candidates and store the plan (and its time) in ``step``.

    Returns the plan and the candidate indices its indices refer to.
    """
    t0 = time.perf_counter()
    state = PlannerState(camera, tuple(loc.views), tuple(step.objects), workspace)
    free = np.setdiff1d(np.arange(len(candidates)), sorted(used))
    plan = plan_from_state(state, candidates[free], config=cfg)
    step.plan, step.plan_s = plan, time.perf_counter() - t0
    return plan, free


def evaluate_step(objects: list[DetectedObject], scene: Scene) -> dict[str, Any]:
    """Errors of one estimate against the truth: matched errors (m), true positives, truth and estimate counts, ellipsoids (mm)."""
    from ..metrics import evaluate, match
    from .information import ellipsoid95_mm

    est = np.array([o.position for o in objects]).reshape(-1, 3)
    met = evaluate(est, scene.centres, truth_radii=scene.radii)
    ei, ti = match(est, scene.centres)
    errors = np.linalg.norm(est[ei] - scene.centres[ti], axis=1) if len(ei) else np.zeros(0)
    gates = np.maximum(scene.radii[ti], 0.02) if len(ti) else np.zeros(0)
    ell = [ellipsoid95_mm(o.covariance) for o in objects if o.covariance is not None]
    return {
        "errors": errors.tolist(),
        "true_positives": met.true_positives,
        "n_truth": met.n_truth,
        "n_estimates": met.n_estimates,
        "ellipsoid_mm": ell,
        "all_within_mm": float(np.max(errors) * 1e3) if len(errors) and met.true_positives == met.n_truth else math.inf,
        "matched_within_gate": bool(np.all(errors <= gates)) if len(errors) else False,
    }


def write_active_simulation(
    directory: str | Path,
    scene: Scene,
    camera: Camera,
    n_views: int,
    *,
    candidates: str = "cap:60",
    noise: NoiseModel | None = None,
    rng: int | None = 0,
    planner: PlannerConfig | None = None,
    figure: bool = True,
) -> dict[str, Path]:
    """``simulate --active N``: run the next-best-view loop and write session, truth, scene, plan and figure.

    Files: ``session.json`` (the views the loop took, reported poses and boxes), ``truth.json``
    (the scene's fruit, ``monovisual3d evaluate`` format), ``scene.json``, ``active.json`` (per
    view: the candidate chosen, its gain, whether the stopping rule said done, the estimate) and
    ``active.png`` (the candidates and the chosen poses in order, with the fruit; needs matplotlib).

    Parameters
    ----------
    candidates : str, a ``cap:`` spec (see :class:`~monovisual3d.active.candidates.CapSpec`) around the
        scene's target, or a candidate file
    """
    from ..sim.scenes import scene_target
    from .candidates import pose_to_dict

    out_dir = Path(directory)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: exists and is not a directory")
    target = scene_target(scene)
    cands, cfg = _simulation_candidates(candidates, target, planner)
    if n_views - 1 > len(cands):
        raise InputError(f"--active: got {n_views} views, but there are only {len(cands)} candidates (+ the first view)")
    run = run_loop(scene, camera, cands, n_views, strategy="nbv", target=target, noise=noise, rng=rng, planner=cfg)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {k: out_dir / f"{k}.json" for k in ("session", "truth", "scene", "active")}
    run.session.to_json(paths["session"])
    paths["truth"].write_text(json.dumps(scene.truth_dict(), indent=2) + "\n")
    scene.save(paths["scene"])
    steps = [_step_record(k, st, len(run.steps), scene) for k, st in enumerate(run.steps)]
    active = {"candidates": [pose_to_dict(T) for T in cands], "steps": steps}
    paths["active"].write_text(json.dumps(active, indent=2) + "\n")
    if figure:
        from ..figures.active import poses_figure

        paths["figure"] = out_dir / "active.png"
        poses_figure(scene, cands, [st.T_base_optical for st in run.steps], [st.objects for st in run.steps][-1]).savefig(
            paths["figure"], dpi=110
        )
    return paths


def _simulation_candidates(
    candidates: str, target: NDArray[np.float64], planner: PlannerConfig | None
) -> tuple[NDArray[np.float64], PlannerConfig]:
    """The candidate poses, shape (N, 4, 4), of a ``cap:`` spec around ``target`` or of a file, and the planner's config.

    Without ``planner``, the default config with the cap's reach (a file: no reach limit).
    """
    from .candidates import CapSpec, cap_poses, load_candidates

    if candidates.strip().startswith("cap:"):
        spec = CapSpec.parse(candidates)
        return cap_poses(spec, target), planner or PlannerConfig(reach_m=spec.reach_m)
    return load_candidates(candidates), planner or PlannerConfig()


def _step_record(k: int, step: LoopStep, n_steps: int, scene: Scene) -> dict[str, Any]:
    """One view's entry of ``active.json``: the candidate, pose, plan (done, gain of the next view, ellipsoids), errors."""
    from .candidates import pose_to_dict

    e = evaluate_step(step.objects, scene)
    plan = step.plan
    return {
        "view": k,
        "candidate": step.candidate,
        "pose": pose_to_dict(step.T_base_optical),
        "done_after": bool(plan.done) if plan is not None else None,
        "gain_of_next": float(plan.gain) if plan is not None and k + 1 < n_steps else None,
        "objects": len(step.objects),
        "mean_error_mm": float(np.mean(e["errors"]) * 1e3) if e["errors"] else None,
        "recall": e["true_positives"] / e["n_truth"] if e["n_truth"] else None,
        "ellipsoid95_mm": [float(x) for x in plan.ellipsoid_mm] if plan is not None else [],
    }
