"""Accuracy benchmark: fixed-seed simulated scenes, every method side by side.

Conditions (the issue's list), each over several seeds:

- ``paper-clean``: the paper's six-sphere scene, its three viewpoints, exact boxes;
- ``paper-noise``: the same with the paper's noise (5 % box noise, 2 % drops);
- ``greenhouse``: tomato trusses with leaves partly occluding fruit (exact visible boxes);
- ``greenhouse-noise``: the same trusses with the paper's box noise, boxes only (the demo's
  setting; twice the seeds, no target: it measures how often occlusion and noise together hide a fruit);
- ``greenhouse-clutter``: the same plus false-positive boxes (1 per image on average, random
  position and size; no target: it measures what clutter costs in precision);
- ``pose-error``: the paper scene, exact boxes, camera poses reported with 2 mm / 0.5 deg error (per axis, 1 std);
  the ``bayes`` methods are told that uncertainty (``pose_sigma_mm``, ``pose_sigma_deg``), as a user would
  state the accuracy of their arm and hand-eye calibration;
- ``n-fruit-N`` for N in 1, 2, 4, 6, 10: random scenes, exact boxes.

Methods: ``bayes`` (default), ``bayes+masks`` (the same with instance masks
from the simulator's label images, where a condition provides them),
``bayes-2cm`` (``bayes`` scoring on a 2 cm grid), ``bayes-strict`` (``bayes`` accepting
an object only from 12 nats instead of 8: fewer false fruit from clutter, more missed
occluded fruit), ``bayes-unstated`` (``bayes`` without what the condition states to it, e.g.
the pose uncertainty of ``pose-error``); these three only when asked; and
``paper`` (Gaussian kernel, sigma = size/2, weighted centre, 10 mm grid).

Per condition and method, errors are pooled over all seeds: mean / median /
max Euclidean error of the Hungarian-matched pairs (mm), recall and
precision with the gate of :func:`monovisual3d.metrics.evaluate` (an
estimate counts only within the true radius, >= 20 mm, of a fruit: ghosts
are false positives), mean radius error (mm) and the median runtime of one
``localize`` call (s, after one untimed warm-up call that loads numba's cached kernels). For ``paper-noise``,
``shapes-noise``, ``greenhouse-noise`` (leaf occlusion) and ``greenhouse-clutter`` (false positives) the
table also gives the RMS error an efficient estimator could reach (the Cramer-Rao bound of the noise model
for the boxes each fruit truly has), to tell estimator error from missing information. In the greenhouse
the bound counts only what each fruit's own boxes say: a false-positive box adds nothing, an edge that a
leaf, another fruit or the image border cuts is left out (:func:`cut_crlb_rms_sq`).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..api import localize
from ..errors import InputError
from ..geometry.sphere import predict_sphere_boxes
from ..masks import encode_rle
from ..metrics import evaluate, match
from ..session import Detection, Session, View
from ..sim.noise import NoiseModel
from ..sim.scene import Scene
from ..sim.scenes import default_camera, greenhouse_scene, paper_scene, random_scene, shapes_scene
from ..sim.simulate import simulate_views
from .timing import machine_metadata

#: Options of each benchmarked method (passed to :func:`monovisual3d.localize`).
METHOD_OPTIONS: dict[str, dict[str, Any]] = {
    "bayes": {"method": "bayes", "use_masks": False},
    "bayes+masks": {"method": "bayes", "use_masks": True},
    "bayes-2cm": {"method": "bayes", "use_masks": False, "resolution": 0.02},
    "bayes-strict": {"method": "bayes", "use_masks": False, "accept": 12.0},
    "bayes-unstated": {"method": "bayes", "use_masks": False},
    "paper": {"method": "paper", "kernel": "gaussian", "centre": "weighted", "resolution": 0.01, "backend": "numba"},
}

#: Methods run without the condition's extra options (what the user states, e.g. the pose uncertainty).
IGNORES_CONDITION_OPTIONS = frozenset({"bayes-unstated"})
#: False-positive boxes per image (Poisson mean) of the ``greenhouse-clutter`` condition.
CLUTTER_RATE = 1.0
#: Camera-pose error of the ``pose-error`` condition (1 std per axis), also the uncertainty stated to the method.
POSE_ERROR_MM, POSE_ERROR_DEG = 2.0, 0.5

#: The issue's targets for the default method: condition -> {metric: (op, value)}.
TARGETS: dict[str, dict[str, tuple[str, float]]] = {
    "paper-clean": {"mean_mm": ("<=", 1.5), "recall": (">=", 1.0), "precision": (">=", 1.0), "radius_mm": ("<=", 1.0)},
    "paper-noise": {"mean_mm": ("<=", 4.0), "recall": (">=", 0.98), "precision": (">=", 0.98)},
    "greenhouse": {"mean_mm": ("<=", 6.0), "recall": (">=", 0.95)},
    "pose-error": {"mean_mm": ("<=", 8.0)},
    "shapes-clean": {"mean_mm": ("<=", 1.5), "semi_axis_mm": ("<=", 2.0), "recall": (">=", 0.98), "precision": (">=", 0.98)},
    "shapes-noise": {"mean_mm": ("<=", 8.0), "recall": (">=", 0.98)},
}


@dataclass(frozen=True)
class Condition:
    """One benchmark condition: a scene generator, a noise model, seeds, and whether masks are offered.

    ``options`` maps a localisation method (the ``method`` of :data:`METHOD_OPTIONS`)
    to extra options for this condition only: what a user would state about
    their setup, e.g. ``{"bayes": {"pose_sigma_mm": 2.0, "pose_sigma_deg": 0.5}}``.
    ``crlb`` adds the Cramer-Rao bound of the box noise: ``"full"`` from each fruit's full
    silhouette boxes (:func:`crlb_rms_sq`, for scenes without occluders), ``"cut"`` from its
    visible boxes with the cut edges left out (:func:`cut_crlb_rms_sq`, for occluded scenes).
    """

    name: str
    description: str
    scene: Callable[[int], Scene]
    noise: NoiseModel
    seeds: tuple[int, ...]
    masks: bool = False
    options: dict[str, dict[str, Any]] = field(default_factory=dict)
    crlb: str = ""

    def method_options(self, method: str) -> dict[str, Any]:
        """Options of a benchmarked method (a key of :data:`METHOD_OPTIONS`) under this condition."""
        base = METHOD_OPTIONS[method]
        if method in IGNORES_CONDITION_OPTIONS:
            return dict(base)
        return {**base, **self.options.get(base["method"], {})}


def conditions(quick: bool = False) -> list[Condition]:
    """The benchmark's conditions; ``quick`` uses fewer seeds and fruit counts (for tests).

    One unit of thought: this is the benchmark's table of conditions (name, what it tests, scene,
    noise, seeds), written as one literal so that a reader sees every condition and how they
    differ side by side; splitting it by scene family would scatter the table, not clarify it.
    """
    n = 2 if quick else 10
    seeds = tuple(range(n))
    out = [
        Condition("paper-clean", "paper scene, 3 paper views, exact boxes", lambda s: paper_scene(), NoiseModel(), (0,)),
        Condition(
            "paper-noise", "paper scene + 5% box noise, 2% drops", lambda s: paper_scene(), NoiseModel.paper(), seeds, crlb="full"
        ),
        Condition(
            "greenhouse",
            "tomato truss, leaf occlusion, exact visible boxes",
            lambda s: greenhouse_scene(rng=s),
            NoiseModel(),
            seeds,
            masks=True,
        ),
        Condition(
            "greenhouse-noise",
            "tomato truss, leaf occlusion + 5% box noise, 2% drops (the demo's setting)",
            lambda s: greenhouse_scene(rng=s),
            NoiseModel.paper(),
            tuple(range(2 * n)),
            crlb="cut",
        ),
        Condition(
            "greenhouse-clutter",
            "the same + 1 false-positive box per image on average",
            lambda s: greenhouse_scene(rng=s),
            NoiseModel.paper(false_positive_rate=CLUTTER_RATE),
            tuple(range(2 * n)),
            crlb="cut",
        ),
        Condition(
            "pose-error",
            "paper scene, poses off by 2 mm / 0.5 deg (stated to bayes)",
            lambda s: paper_scene(),
            NoiseModel.from_mm_deg(pose_error_mm=POSE_ERROR_MM, pose_error_deg=POSE_ERROR_DEG),
            seeds,
            options={"bayes": {"pose_sigma_mm": POSE_ERROR_MM, "pose_sigma_deg": POSE_ERROR_DEG}},
        ),
    ]
    out += [
        Condition(
            "shapes-clean",
            "six fruit of mixed shapes (oblate tomatoes, peppers, cucumbers, apples, plums), exact boxes",
            lambda s: shapes_scene("mixed", rng=s),
            NoiseModel(),
            seeds,
        ),
        Condition(
            "shapes-noise",
            "the same + 5% box noise, 2% drops",
            lambda s: shapes_scene("mixed", rng=s),
            NoiseModel.paper(),
            seeds,
            crlb="full",
        ),
        Condition(
            "shapes-occluded",
            "mixed shapes, fruit may hide up to 40% of each other, exact visible boxes",
            lambda s: shapes_scene("mixed", rng=s, min_visible_fraction=0.6, min_gap=0.0),
            NoiseModel(),
            seeds,
        ),
    ]
    for k in (1, 2, 6) if quick else (1, 2, 4, 6, 10):
        out.append(
            Condition(
                f"n-fruit-{k}",
                f"{k} random fruit, exact boxes",
                lambda s, k=k: random_scene(k, rng=1000 + s),
                NoiseModel(),
                seeds[: max(1, n // 2)],
            )
        )
    return out


@dataclass
class Pool:
    """Errors pooled over the runs of one (condition, method)."""

    errors: list[float] = field(default_factory=list)
    radius_errors: list[float] = field(default_factory=list)
    semi_axis_errors: list[float] = field(default_factory=list)
    runtimes: list[float] = field(default_factory=list)
    n_truth: int = 0
    n_estimates: int = 0
    true_positives: int = 0
    bound_sq: list[float] = field(default_factory=list)

    def add(self, values: dict[str, Any]) -> None:
        """Add one seed's values (a dict of :func:`measure_seed`): lists are extended, counts summed."""
        for key, value in values.items():
            setattr(self, key, getattr(self, key) + value)

    def summary(self) -> dict[str, Any]:
        e = np.asarray(self.errors) * 1e3
        out: dict[str, Any] = {
            "runs": len(self.runtimes),
            "n_truth": self.n_truth,
            "n_estimates": self.n_estimates,
            "mean_mm": float(e.mean()) if len(e) else float("nan"),
            "median_mm": float(np.median(e)) if len(e) else float("nan"),
            "max_mm": float(e.max()) if len(e) else float("nan"),
            "rms_mm": float(np.sqrt(np.mean(e**2))) if len(e) else float("nan"),
            "recall": self.true_positives / self.n_truth if self.n_truth else float("nan"),
            "precision": self.true_positives / self.n_estimates if self.n_estimates else float("nan"),
            "radius_mm": float(np.mean(self.radius_errors) * 1e3) if self.radius_errors else None,
            "semi_axis_mm": float(np.mean(self.semi_axis_errors) * 1e3) if self.semi_axis_errors else None,
            "runtime_s": float(np.median(self.runtimes)) if self.runtimes else float("nan"),
        }
        if self.bound_sq:
            out["rms_bound_mm"] = float(np.sqrt(np.mean(self.bound_sq)) * 1e3)
        return out


def simulated_session(scene: Scene, noise: NoiseModel, seed: int, *, masks: bool) -> tuple[Session, list[Any]]:
    """Simulate the paper's three views of ``scene``; with ``masks``, attach each true detection's visible mask (RLE)."""
    camera = default_camera()
    svs = simulate_views(scene, camera, noise=noise, rng=seed)
    views = []
    for sv in svs:
        dets = []
        for box, fruit in zip(sv.boxes_xyxy, sv.source):
            mask = encode_rle(sv.rendering.labels == fruit) if masks and fruit >= 0 else None
            dets.append(Detection(np.asarray(box, dtype=float), label="tomato", mask=mask))
        views.append(View(sv.T_base_optical_reported, tuple(dets)))
    return Session(camera, tuple(views)), svs


def crlb_rms_sq(scene: Scene, svs: list[Any], box_sigma: float) -> list[float]:
    """Per fruit: trace of the Cramer-Rao bound of its centre (m^2) under the relative box-noise model.

    Only views in which the fruit was detected count; its box is the exact
    silhouette box (border clipping ignored). Noise per box: centre std
    ``box_sigma * size``, size std ``box_sigma * size`` (see
    :mod:`monovisual3d.sim.noise`), i.e. edge covariance
    ``sigma^2 size^2 [[1.25, 0.75], [0.75, 1.25]]`` per axis.
    """
    camera = default_camera()
    if any(getattr(f, "semi_axes", None) is not None and np.ptp(np.asarray(f.semi_axes)) > 0 for f in scene.fruits):
        return _shape_crlb_rms_sq(camera, scene, svs, box_sigma)
    out = []
    for f, (c, r) in enumerate(zip(scene.centres, scene.radii)):
        F = np.zeros((4, 4))
        for sv in svs:
            if f not in set(sv.source.tolist()):
                continue
            T_ob = np.linalg.inv(sv.T_base_optical_true)

            def edges(p: NDArray[np.float64], T_ob: NDArray[np.float64] = T_ob) -> NDArray[np.float64]:
                po = T_ob[:3, :3] @ p[:3] + T_ob[:3, 3]
                return predict_sphere_boxes(camera, po[None], np.array([p[3]]))[0][0, 0]

            p0 = np.r_[c, r]
            J = np.stack([(edges(p0 + h) - edges(p0 - h)) / (2e-6) for h in np.eye(4) * 1e-6], axis=1)
            b = edges(p0)
            C = np.zeros((4, 4))
            for i, j in ((0, 2), (1, 3)):
                s2 = (box_sigma * (b[j] - b[i])) ** 2
                C[np.ix_([i, j], [i, j])] = s2 * np.array([[1.25, 0.75], [0.75, 1.25]])
            F += J.T @ np.linalg.solve(C, J)
        try:
            out.append(float(np.trace(np.linalg.inv(F)[:3, :3])))
        except np.linalg.LinAlgError:
            out.append(float("nan"))
    return [v for v in out if np.isfinite(v)]


def _semi_axis_errors(objects: list[Any], scene: Scene, ei: Any, ti: Any) -> list[float]:
    """Mean |sorted estimated - sorted true semi-axes| (metres) per matched pair, for scenes with non-spherical fruit."""
    if not any(getattr(f, "semi_axes", None) is not None and np.ptp(np.asarray(f.semi_axes)) > 0 for f in scene.fruits):
        return []
    out = []
    for e, t in zip(ei, ti):
        o, f = objects[e], scene.fruits[t]
        if o.semi_axes is None and o.radius is None:  # a method without sizes (paper)
            continue
        est = np.sort(o.semi_axes) if o.semi_axes is not None else np.full(3, float(o.radius))
        true = np.sort(np.asarray(getattr(f, "semi_axes", None) if getattr(f, "semi_axes", None) is not None else [f.radius] * 3))
        out.append(float(np.mean(np.abs(est - true))))
    return out


def _shape_crlb_rms_sq(camera: Any, scene: Scene, svs: list[Any], box_sigma: float) -> list[float]:
    """:func:`crlb_rms_sq` for scenes with non-spherical fruit: each fruit's bound under its own shape model."""
    from ..geometry.bounds import centre_crlb_rms_sq

    out: list[float] = []
    for f, fruit in enumerate(scene.fruits):
        e = fruit.ellipsoid
        poses = [sv.T_base_optical_true for sv in svs if f in set(sv.source.tolist())]
        out += centre_crlb_rms_sq(camera, [e], [np.array(poses).reshape(-1, 4, 4)], box_sigma, model=e.shape)
    return out


def cut_crlb_rms_sq(scene: Scene, svs: list[Any], box_sigma: float) -> list[float]:
    """Per fruit: trace of the Cramer-Rao bound of its centre (m^2) from the boxes it truly has.

    The views are those whose detections include one of the fruit (true association: false
    positives and other fruit's boxes add nothing); the noise scales with the fruit's visible
    box (as the simulator's does); an edge of the visible box more than
    :data:`~monovisual3d.geometry.bounds.CUT_PX` inside the full silhouette box (a leaf, another
    fruit or the border cuts it) is left out, its place being unknown to the estimator
    (:func:`~monovisual3d.geometry.bounds.cut_edges`). Each fruit under its own shape model.
    """
    from ..geometry.bounds import cut_edges, ellipsoid_crlb
    from ..geometry.ellipsoid import ellipsoid_bbox

    camera = default_camera()
    out: list[float] = []
    for f, fruit in enumerate(scene.fruits):
        views = [sv for sv in svs if f in set(sv.source.tolist())]
        if not views:
            continue
        e = fruit.ellipsoid
        T = np.array([sv.T_base_optical_true for sv in views])
        seen = np.array([sv.rendering.boxes_xyxy[f] for sv in views])
        full = ellipsoid_bbox(camera, T, e.centre_base, e.semi_axes, e.rotation, clip=False)
        b = ellipsoid_crlb(camera, T, e, box_sigma, e.shape, censored=cut_edges(full, seen), noise_boxes_xyxy=seen)
        if np.isfinite(b.centre_rms_sq):
            out.append(b.centre_rms_sq)
    return out


def _bound_sq(cond: Condition, scene: Scene, svs: list[Any]) -> list[float]:
    """The condition's per-fruit centre bounds (m^2): none, from full boxes, or from the cut visible boxes."""
    if cond.crlb == "full":
        return crlb_rms_sq(scene, svs, cond.noise.box_sigma)
    if cond.crlb == "cut":
        return cut_crlb_rms_sq(scene, svs, cond.noise.box_sigma)
    return []


def run_accuracy(
    *,
    quick: bool = False,
    methods: tuple[str, ...] = ("bayes", "bayes+masks", "paper"),
    only: tuple[str, ...] | None = None,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> dict[str, Any]:
    """Run every condition (or those named in ``only``) with every method; returns a JSON-ready dict.

    With ``workers`` (local processes) or ``scheduler`` (a running Dask cluster) the seeds are
    spread over Dask (:func:`monovisual3d.batch.spread.spread_map`); the errors are the same,
    the runtimes are then those of single-threaded workers.
    """
    from ..batch.spread import check_spread, spread_map

    unknown = sorted(set(methods) - set(METHOD_OPTIONS))
    if unknown:
        raise InputError(f"methods: unknown {unknown[0]!r}, expected some of {sorted(METHOD_OPTIONS)}")
    check_spread(workers, scheduler)
    conds = [c for c in conditions(quick) if only is None or c.name in only]
    if only is not None and len(conds) != len(set(only)):
        raise InputError(f"only: expected condition names from {[c.name for c in conditions(quick)]}, got {list(only)}")
    items = [(c.name, quick, seed, methods) for c in conds for seed in c.seeds]

    def tick(i: int, _: Any) -> None:
        if progress is not None:
            progress(f"{items[i][0]} seed {items[i][2]}")

    measured = spread_map(measure_seed, items, workers=workers, scheduler=scheduler, progress=tick)
    results: dict[str, dict[str, Any]] = {}
    for cond in conds:
        pools = {m: Pool() for m in methods if m != "bayes+masks" or cond.masks}
        for item, per_method in zip(items, measured):
            if item[0] == cond.name:
                for m, values in per_method.items():
                    pools[m].add(values)
        results[cond.name] = {
            "description": cond.description,
            "seeds": list(cond.seeds),
            "options": cond.options,
            "methods": {m: p.summary() for m, p in pools.items()},
        }
    spread = None if not workers and scheduler is None else {"workers": workers, "scheduler": scheduler}
    return {
        "benchmark": "accuracy",
        "quick": quick,
        "machine": machine_metadata(),
        "spread": spread,
        "results": results,
        "targets": TARGETS,
    }


#: Methods whose kernels this process has loaded (the untimed warm-up of :func:`measure_seed`).
_WARM: set[str] = set()


def measure_seed(name: str, quick: bool, seed: int, methods: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """One seed of one condition with every method: per method, the values a :class:`Pool` adds up.

    The first call in a process first localises a small scene with each method, untimed, so that
    numba's cached kernels are loaded, as in a long-running robot process.
    """
    cond = next(c for c in conditions(quick) if c.name == name)
    if not _WARM.issuperset(methods):
        warm, _ = simulated_session(random_scene(2, rng=0), NoiseModel(), 0, masks=False)
        for m in methods:
            localize(warm, **METHOD_OPTIONS[m])
        _WARM.update(methods)
    scene = cond.scene(seed)
    session, svs = simulated_session(scene, cond.noise, seed, masks=cond.masks)
    out: dict[str, dict[str, Any]] = {}
    for m in methods:
        if m == "bayes+masks" and not cond.masks:
            continue
        t0 = time.perf_counter()
        res = localize(session, **cond.method_options(m))
        runtime = time.perf_counter() - t0
        est = res.positions
        est_r = np.array([o.radius if o.radius is not None else np.nan for o in res.objects])
        met = evaluate(est, scene.centres, truth_radii=scene.radii, estimate_radii=est_r)
        ei, ti = match(est, scene.centres)
        ok = np.isfinite(est_r[ei]) if len(ei) else np.zeros(0, bool)
        out[m] = {
            "errors": np.linalg.norm(est[ei] - scene.centres[ti], axis=1).tolist(),
            "radius_errors": np.abs(est_r[ei][ok] - scene.radii[ti][ok]).tolist(),
            "semi_axis_errors": _semi_axis_errors(res.objects, scene, ei, ti),
            "runtimes": [runtime],
            "n_truth": met.n_truth,
            "n_estimates": met.n_estimates,
            "true_positives": met.true_positives,
            "bound_sq": _bound_sq(cond, scene, svs) if m == "bayes" else [],
        }
    return out


def check_targets(results: dict[str, Any]) -> list[tuple[str, str, float, str, float, bool]]:
    """(condition, metric, value, op, target, met) for each of the default method's targets."""
    rows = []
    for cond, targets in TARGETS.items():
        if cond not in results["results"]:
            continue
        summary = results["results"][cond]["methods"].get("bayes", {})
        for metric, (op, target) in targets.items():
            value = summary.get(metric)
            if value is None:
                continue
            met = value <= target + 1e-12 if op == "<=" else value >= target - 1e-12
            rows.append((cond, metric, float(value), op, target, bool(met)))
    return rows


def format_markdown(results: dict[str, Any]) -> str:
    """The benchmark table (Markdown), one row per condition and method, then the target check."""
    m = results["machine"]
    lines = [
        f"Machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}, numba {m.get('numba')}; "
        f"{m['date_utc'][:10]}, load average {m.get('load_average_1m', float('nan')):.1f}"
        + (" (quick mode)" if results["quick"] else "")
        + ("; seeds spread over Dask, runtimes of single-threaded workers" if results.get("spread") else ""),
        "",
        "| condition | method | runs | mean mm | median mm | max mm | recall | precision | radius err mm | semi-axis err mm | runtime s |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]

    def f(v: Any, d: int = 2) -> str:
        return "-" if v is None or (isinstance(v, float) and np.isnan(v)) else f"{v:.{d}f}"

    for cond, block in results["results"].items():
        for meth, s in block["methods"].items():
            lines.append(
                f"| {cond} | {meth} | {s['runs']} | {f(s['mean_mm'])} | {f(s['median_mm'])} | {f(s['max_mm'])} | "
                f"{f(s['recall'], 3)} | {f(s['precision'], 3)} | {f(s['radius_mm'])} | {f(s.get('semi_axis_mm'))} | {f(s['runtime_s'], 3)} |"
            )
    bounds = [
        (c, b["methods"]["bayes"]) for c, b in results["results"].items() if "rms_bound_mm" in b["methods"].get("bayes", {})
    ]
    if bounds:
        lines += ["", "| condition | bayes RMS error mm | Cramer-Rao RMS bound mm | ratio |", "|---|---:|---:|---:|"]
        lines += [
            f"| {c} | {f(s['rms_mm'])} | {f(s['rms_bound_mm'])} | {f(s['rms_mm'] / s['rms_bound_mm'])} |" for c, s in bounds
        ]
    checks = check_targets(results)
    if checks:
        lines += ["", "| target (default method) | measured | target | met |", "|---|---:|---:|:---:|"]
    for cond, metric, value, op, target, met in checks:
        lines.append(f"| {cond} {metric} | {value:.3f} | {op} {target:g} | {'yes' if met else 'NO'} |")
    return "\n".join(lines) + "\n"


def save(results: dict[str, Any], path: str) -> None:
    with open(path, "w") as fh:
        json.dump(results, fh, indent=2)
