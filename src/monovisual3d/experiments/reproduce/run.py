"""Running the reproduction: simulate the sessions, localise, record each run, then write the outputs.

:func:`reproduce` is the entry point; it runs the paper-scene experiments
(noise-free and noisy, every ordering, both kernels, every threshold) and the
ghost study, records each run (:mod:`.aggregate`), and writes ``results.json``,
the figures (:mod:`.figures`) and ``report.md`` (:mod:`.report`).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...api import localize
from ...camera import Camera
from ...errors import InputError, InputWarning
from ...grid import VoxelGrid
from ...methods.paper.config import PaperConfig
from ...methods.paper.engine.params import KERNELS
from ...methods.paper.filter import HistogramFilter
from ...methods.paper.kmeans import CENTRES
from ...result import DetectedObject
from ...session import Session
from ...sim.noise import NoiseModel
from ...sim.scene import Scene
from ...sim.scenes import default_camera, paper_scene, random_scene, scene_target
from ...sim.simulate import simulate
from ...sim.viewpoints import paper_poses, pose_permutations
from .aggregate import ReproduceResult, RunRecord, record_run
from .config import NOISE_FREE, NOISY, ProgressFn, ReproduceConfig

#: Posterior after each view of one paper-filter run, per kernel: the grid and the snapshots.
Snapshots = dict[str, tuple[VoxelGrid, list[NDArray[np.float64]]]]


def reorder_session(session: Session, order: Sequence[int]) -> Session:
    """The same session with its views in another order (the camera and workspace unchanged).

    Examples
    --------
    >>> from monovisual3d.sim.scenes import paper_scene
    >>> s, _ = simulate(paper_scene(), rng=0)
    >>> reorder_session(s, (2, 0, 1)).views[0] is s.views[2]
    True
    """
    if sorted(order) != list(range(len(session.views))):
        raise InputError(f"order: got {tuple(order)!r}, expected a permutation of 0..{len(session.views) - 1}")
    return Session(session.camera, tuple(session.views[i] for i in order), session.workspace, session.source)


def off_fruit_mass(grid: VoxelGrid, posterior: NDArray[np.floating], keep_threshold: float, scene: Scene) -> tuple[float, int]:
    """Share of the clustered cells' posterior mass that lies outside every true sphere, and their count.

    The clustered cells are those with ``p >= keep_threshold * max(p)`` (the
    cells k-means sees). Mass off the fruit is ghost mass (viewing-cone
    intersections of different fruit) plus the blur around the true fruit.

    Returns
    -------
    fraction : float in [0, 1] (NaN for an empty posterior)
    n_cells : int
    """
    p = np.asarray(posterior, dtype=float).ravel()
    if p.size == 0 or p.max() <= 0:
        return math.nan, 0
    keep = np.flatnonzero(p >= keep_threshold * p.max())
    x = grid.centres_base(keep)
    d = np.linalg.norm(x[:, None, :] - scene.centres[None, :, :], axis=-1)
    on = np.any(d <= scene.radii[None, :], axis=1)
    w = p[keep]
    return float(w[~on].sum() / w.sum()), len(keep)


def _run_paper(
    session: Session, camera: Camera, kernel: str, sigma_fraction: float, cfg: ReproduceConfig, keep_history: bool
) -> tuple[HistogramFilter, int, float]:
    """Run the paper filter over the views; returns the filter, the number of skipped views and the seconds."""
    t0 = time.perf_counter()
    filt = HistogramFilter(
        camera,
        PaperConfig(
            kernel=kernel,
            sigma_fraction=sigma_fraction,
            resolution=cfg.resolution,
            reach=cfg.reach,
            keep_threshold=cfg.keep_threshold,
        ),
        keep_history=keep_history,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)  # skips are counted below and reported
        for view in session.views:
            filt.update(view)
    return filt, len(session.views) - len(filt.views_used), time.perf_counter() - t0


def _run_bayes(session: Session) -> tuple[list[DetectedObject], float]:
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        result = localize(session, method="bayes")
    return result.objects, time.perf_counter() - t0


def _off_fruit(filt: HistogramFilter, keep_threshold: float, scene: Scene) -> tuple[float, int]:
    post = filt.posterior
    if post is None or filt.grid is None:
        return math.nan, 0
    return off_fruit_mass(filt.grid, post, keep_threshold, scene)


@dataclass(frozen=True)
class _Plan:
    """What one reproduction runs: the paper scene, its views, the experiments and the step count."""

    camera: Camera
    scene: Scene
    poses: NDArray[np.float64]
    orderings: tuple[tuple[int, ...], ...]
    experiments: tuple[tuple[str, int | None, NoiseModel, float], ...]
    thresholds: tuple[float, ...]
    total: int

    @classmethod
    def from_config(cls, cfg: ReproduceConfig) -> _Plan:
        camera = default_camera()
        scene = paper_scene()
        poses = paper_poses(scene_target(scene))
        orderings = cfg.orderings or tuple(order for order, _ in pose_permutations(poses))
        seeds = range(cfg.seed, cfg.seed + cfg.seeds)
        noise = NoiseModel(box_sigma=cfg.box_sigma, drop_probability=cfg.drop_probability)
        experiments = ((NOISE_FREE, None, NoiseModel(), cfg.sigma_fraction_noise_free),) + tuple(
            (NOISY, s, noise, cfg.sigma_fraction_noisy) for s in seeds
        )
        per_session = len(orderings) * (len(KERNELS) + (1 if cfg.bayes else 0))
        total = len(experiments) * per_session + len(cfg.ghost_counts) * cfg.ghost_scenes + (1 if cfg.figures else 0)
        thresholds = tuple(sorted({cfg.keep_threshold, *cfg.thresholds}))
        return cls(camera, scene, poses, tuple(orderings), experiments, thresholds, total)


class _Progress:
    """Counts steps and forwards them to the user's ``progress`` callback."""

    def __init__(self, total: int, progress: ProgressFn | None) -> None:
        self.done, self.total, self.progress = 0, total, progress

    def __call__(self, what: str) -> None:
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total, what)


def _paper_experiment(cfg: ReproduceConfig, index: int) -> tuple[list[RunRecord], Snapshots, list[str]]:
    """One experiment of the paper scene (noise-free, or one noisy seed): every ordering and kernel.

    Returns the records, the posterior snapshots (noise-free experiment, first ordering) and
    the steps done (one per ordering and kernel, for the progress bar).
    """
    plan = _Plan.from_config(cfg)
    records: list[RunRecord] = []
    snapshots: Snapshots = {}
    steps: list[str] = []
    scene, camera = plan.scene, plan.camera
    experiment, seed, nm, sigma_fraction = plan.experiments[index]
    session, _ = simulate(scene, camera, plan.poses, noise=nm, rng=seed)
    for order in plan.orderings:
        s = reorder_session(session, order)
        for kernel in KERNELS:
            keep_history = experiment == NOISE_FREE and order == plan.orderings[0]
            filt, skipped, secs = _run_paper(s, camera, kernel, sigma_fraction, cfg, keep_history)
            if keep_history and filt.grid is not None and filt.history:
                snapshots[kernel] = (filt.grid, list(filt.history))
            for thr in plan.thresholds:
                centres = CENTRES if math.isclose(thr, cfg.keep_threshold) else ("weighted",)
                mass, n_cells = _off_fruit(filt, thr, scene)
                for centre in centres:
                    objs = filt.estimate(centre=centre, keep_threshold=thr)
                    records.append(
                        record_run(
                            experiment,
                            "paper",
                            kernel,
                            centre,
                            thr,
                            order,
                            seed,
                            scene,
                            objs,
                            off_fruit_mass=mass,
                            n_clustered=n_cells,
                            skipped_views=skipped,
                            seconds=secs,
                        )
                    )
            steps.append(f"{experiment} {kernel} {''.join(map(str, order))}" + (f" seed {seed}" if seed is not None else ""))
        if cfg.bayes:
            objs, secs = _run_bayes(s)
            records.append(record_run(experiment, "bayes", "-", "-", math.nan, order, seed, scene, objs, seconds=secs))
            steps.append(f"{experiment} bayes {''.join(map(str, order))}")
    return records, snapshots, steps


def _ghost_scene(cfg: ReproduceConfig, n: int, i: int) -> tuple[list[RunRecord], Snapshots, list[str]]:
    """Experiment 4, one random noise-free scene of ``n`` fruit: both kernels (weighted centre) and bayes."""
    camera = default_camera()
    records: list[RunRecord] = []
    scene_seed = cfg.ghost_seed + 100 * n + i
    sc = random_scene(n, rng=scene_seed)
    session, _ = simulate(sc, camera, paper_poses(scene_target(sc)))
    for kernel in KERNELS:
        filt, skipped, secs = _run_paper(session, camera, kernel, cfg.sigma_fraction_noise_free, cfg, False)
        mass, n_cells = _off_fruit(filt, cfg.keep_threshold, sc)
        objs = filt.estimate(centre="weighted")
        records.append(
            record_run(
                "ghost",
                "paper",
                kernel,
                "weighted",
                cfg.keep_threshold,
                (0, 1, 2),
                scene_seed,
                sc,
                objs,
                off_fruit_mass=mass,
                n_clustered=n_cells,
                skipped_views=skipped,
                seconds=secs,
            )
        )
    if cfg.bayes:
        objs, secs = _run_bayes(session)
        records.append(record_run("ghost", "bayes", "-", "-", math.nan, (0, 1, 2), scene_seed, sc, objs, seconds=secs))
    return records, {}, [f"ghost study: {n} fruit, scene {i + 1}/{cfg.ghost_scenes}"]


def run_unit(cfg: ReproduceConfig, kind: str, *args: int) -> tuple[list[RunRecord], Snapshots, list[str]]:
    """One independent unit of the reproduction (a Dask task with ``workers``/``scheduler``), on one thread.

    ``kind`` ``"paper"`` with the experiment's index, or ``"ghost"`` with the fruit count and the scene's index.
    """
    from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

    # k-means (scikit-learn, OpenMP) on a few thousand cells is 5-30x slower with a thread pool than with one
    # thread when the machine is busy; every step here is small, so one thread is also the fastest when it is idle.
    with threadpool_limits(limits=1):
        return _paper_experiment(cfg, *args) if kind == "paper" else _ghost_scene(cfg, *args)


def _units(cfg: ReproduceConfig, plan: _Plan) -> list[tuple[Any, ...]]:
    """The reproduction's units in order: the paper-scene experiments, then the ghost-study scenes."""
    paper = [(cfg, "paper", k) for k in range(len(plan.experiments))]
    return paper + [(cfg, "ghost", n, i) for n in cfg.ghost_counts for i in range(cfg.ghost_scenes)]


def reproduce(
    output: str | Path,
    config: ReproduceConfig | None = None,
    *,
    progress: ProgressFn | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> ReproduceResult:
    """Run the experiments and write ``report.md``, ``results.json`` and the figures into ``output``.

    Parameters
    ----------
    output : directory (created if needed)
    config : ReproduceConfig, default settings when omitted (:meth:`ReproduceConfig.quick_config` for a fast run)
    progress : callable ``(done, total, description)``, called after each step
    workers : int, spread the experiments and scenes over a local Dask cluster of this many processes
    scheduler : str, spread them over a running Dask cluster (``tcp://host:8786``) instead

    Returns
    -------
    ReproduceResult

    Examples
    --------
    >>> import tempfile
    >>> r = reproduce(tempfile.mkdtemp(), ReproduceConfig.quick_config(figures=False))  # doctest: +SKIP
    >>> r.report.name  # doctest: +SKIP
    'report.md'
    """
    from ...batch.spread import check_spread

    check_spread(workers, scheduler)
    return _reproduce(output, config or ReproduceConfig(), progress, workers, scheduler)


def _reproduce(
    output: str | Path, cfg: ReproduceConfig, progress: ProgressFn | None, workers: int | None, scheduler: str | None
) -> ReproduceResult:
    from ...batch.spread import spread_map
    from .figures import write_figures
    from .report import render_report

    out = Path(output)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    plan = _Plan.from_config(cfg)
    tick = _Progress(plan.total, progress)
    t_experiments = time.perf_counter()
    units = _units(cfg, plan)
    n_paper = len(plan.experiments)
    finished: dict[str, float] = {}

    def done(i: int, result: tuple[list[RunRecord], Snapshots, list[str]]) -> None:
        for what in result[2]:
            tick(what)
        finished["paper" if i < n_paper else "ghost"] = time.perf_counter()

    outcomes = spread_map(run_unit, units, workers=workers, scheduler=scheduler, progress=done)
    records = [r for recs, _, _ in outcomes for r in recs]
    snapshots: Snapshots = {k: v for _, snaps, _ in outcomes for k, v in snaps.items()}
    t_figures = time.perf_counter()
    t_ghost = finished.get("paper", t_experiments)  # in this process: when the last paper-scene experiment ended
    result = ReproduceResult(cfg, records, out / "report.md", {}, 0.0, [])
    if cfg.figures:
        try:
            result.files.update(write_figures(out, result, plan.scene, plan.camera, plan.poses, plan.orderings, snapshots))
        except ImportError as exc:
            result.notes.append(f"figures skipped: {exc}")
        tick("figures")
    t_end = time.perf_counter()
    result.seconds = t_end - t_start
    timing = {"figures": t_end - t_figures, "total": t_end - t_start}
    if workers or scheduler is not None:  # units overlap on a cluster: only their span is a wall-clock time
        timing = {"experiments and ghost study (spread over Dask)": t_figures - t_experiments, **timing}
    else:
        timing = {"paper scene experiments": t_ghost - t_experiments, "ghost study": t_figures - t_ghost, **timing}
    results_path = out / "results.json"
    payload = {"config": asdict(cfg), "timing_s": timing, "records": [r.to_dict() for r in records]}
    results_path.write_text(json.dumps(payload, indent=1) + "\n")
    result.files["results"] = results_path
    result.report.write_text(render_report(result, plan.scene, plan.camera, timing, plan.orderings))
    result.files["report"] = result.report
    return result
