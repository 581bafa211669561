"""Real-data benchmark: the methods on a real multi-view scene in the LfD layout (default: the shared Aldoma set).

Every method runs on all the views together and on every subset of ``subset_size`` (3) views:

- ``bayes``: boxes pooled per view (no association), ``size_range`` 0.02-0.15 m;
- ``paper``: boxes pooled per view, the method's defaults;
- ``quadric (tracks)``: LfD's dual quadric given the association (the files' columns as track ids);
- ``quadric (bayes)``: the same solve on the association ``bayes`` finds from the pooled boxes.

The search region is the paper's cube of side ``2 reach`` in front of the first view, with ``reach``
1.0 m for every method: the Aldoma cameras are 1.0-1.4 m from the objects, beyond the default 0.6 m
(a 1.2 m deep cube, which leaves the farthest object out of ``bayes``' and ``paper``'s search).

Scoring (the conventions of :mod:`monovisual3d.metrics`): estimates are matched to the true centres by
the Hungarian assignment on centre distance. Errors (mm) are the distances of every matched pair, however
far apart, pooled over objects (and subsets); a true object without an estimate adds no error but counts
as missed. Missed: true objects with no estimate within the gate (the true object's volume-equivalent
radius, at least 20 mm: the default gate of ``monovisual3d evaluate``), so a far estimate counts both in
the errors and as a miss (and as an extra estimate).
"""

from __future__ import annotations

import itertools
import json
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..api import localize
from ..errors import InputError, one_line
from ..io.lfd import read_lfd
from ..metrics import MIN_GATE_M, match
from ..session import Session
from .timing import machine_metadata
from .trust_runs import NEES_95

#: Where the shared Aldoma set lies, relative to the repository root (and to the working directory).
ALDOMA_RELATIVE = Path("..") / "shared" / "data" / "aldoma"
#: Search reach of every method, metres (see the module docstring).
REACH_M = 1.0
#: Semi-axis range given to ``bayes`` (and to its association for ``quadric``), metres: objects 80-240 mm tall.
SIZE_RANGE_M = (0.02, 0.15)
#: Benchmarked runs: label -> (method, options, whether the session carries the track ids).
RUNS: dict[str, tuple[str, dict[str, Any], bool]] = {
    "bayes": ("bayes", {"size_range": SIZE_RANGE_M}, False),
    "paper": ("paper", {}, False),
    "quadric (tracks)": ("quadric", {}, True),
    "quadric (bayes)": ("quadric", {"association": "bayes", "size_range": SIZE_RANGE_M}, False),
}
#: Short names of :data:`RUNS` for ``--methods``: ``quadric`` is both quadric runs.
RUN_ALIASES: dict[str, tuple[str, ...]] = {"quadric": ("quadric (tracks)", "quadric (bayes)")}
#: LfD's figures on the Aldoma set, given the association (its public code; the issue and the set's README).
LFD_PUBLISHED = {"all": {"mean_mm": 6.1}, "subsets": {"mean_mm": 12.5, "p90_mm": 21.0}}


def default_folder() -> Path | None:
    """The shared Aldoma set, if present: ``../shared/data/aldoma`` from the repository root or the working directory."""
    repo = Path(__file__).resolve().parents[3]
    for base in (repo, Path.cwd()):
        folder = base / ALDOMA_RELATIVE
        if (folder / "bounding_boxes.npy").is_file():
            return folder.resolve()
    return None


def resolve_folder(folder: str | Path | None) -> Path:
    """``folder``, or the shared Aldoma set; a one-line error when neither is there."""
    if folder is None:
        found = default_folder()
        if found is None:
            raise InputError(
                f"DIR: not given, and the shared Aldoma set is not at {ALDOMA_RELATIVE} (from the repository or the working "
                "directory); give the folder of LfD arrays"
            )
        return found
    path = Path(folder)
    if not path.is_dir():
        raise InputError(f"{one_line(str(path))}: not a folder, expected the LfD arrays (intrinsics.npy, camera_poses.npy, ...)")
    return path


def view_sets(n_views: int, subset_size: int) -> list[tuple[int, ...]]:
    """All the views, then every subset of ``subset_size`` views (in lexicographic order)."""
    return [tuple(range(n_views))] + list(itertools.combinations(range(n_views), subset_size))


def score(estimates: np.ndarray, truth: np.ndarray, gates: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Hungarian scoring: per true object the distance (m) to its matched estimate (NaN: none), missed, extra.

    Missed and extra count the pairs beyond the gate (m, per true object) as unmatched.
    """
    ei, ti = match(estimates, truth)
    d = np.full(len(truth), np.nan)
    if len(ei):
        d[ti] = np.linalg.norm(estimates[ei] - truth[ti], axis=1)
    within = int(np.sum(d <= gates))  # NaN compares False
    return d, len(truth) - within, len(estimates) - within


#: Runs (label, folder) this process has made once untimed, so that numba's cached kernels are loaded (as in
#: a long-running process) before the timed runs.
_WARM: set[tuple[str, str]] = set()


def measure(
    folder: str, label: str, views: tuple[int, ...], reach: float, image_size: tuple[int, int] | None = None
) -> dict[str, Any]:
    """One run: method ``label`` of :data:`RUNS` on the given views: per true object the error (m, NaN: no estimate),
    missed, extra, runtime (s), number of warnings."""
    method, options, tracks = RUNS[label]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the loader's notes (a box clipped to the image), said once by run_real
        session, truth = read_lfd(folder, keep_association=tracks, image_size=image_size)
    assert truth is not None
    centres = np.array([o["position"] for o in truth["objects"]])
    gates = np.maximum([o["radius"] for o in truth["objects"]], MIN_GATE_M)
    sub = Session(session.camera, tuple(session.views[i] for i in views))
    if (label, folder) not in _WARM:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            localize(sub, method=method, reach=reach, **options)
        _WARM.add((label, folder))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        result = localize(sub, method=method, reach=reach, **options)
        runtime = time.perf_counter() - t0
    distances, missed, extra = score(result.positions, centres, gates)
    return {
        "errors": [float(x) for x in distances],
        "nees": nees_per_object(result, centres, gates),
        "missed": missed,
        "extra": extra,
        "n_truth": len(centres),
        "runtime_s": runtime,
        "warnings": len(result.warnings) or len(caught),
    }


def nees_per_object(result: Any, truth: np.ndarray, gates: np.ndarray) -> list[float]:
    """Per true object, the NEES of the estimate paired with it (``e^T C^-1 e``, ``e`` the error, ``C`` the estimate's
    covariance); NaN where no estimate is paired within the gate (m) or it has no covariance."""
    out = [float("nan")] * len(truth)
    positions = np.asarray(result.positions, dtype=float).reshape(-1, 3)
    for e, t in zip(*match(positions, truth)):
        cov = result.objects[e].covariance
        err = positions[e] - truth[t]
        if cov is not None and np.linalg.norm(err) <= gates[t]:
            out[t] = float(err @ np.linalg.solve(np.asarray(cov, dtype=float), err))
    return out


def summarise(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Pooled statistics of runs: mean, median, p90, max (mm), missed (of which ``no_estimate``: no estimate
    paired at all) and extra counts, median runtime (s)."""
    e = np.array([x for r in runs for x in r["errors"] if np.isfinite(x)]) * 1e3
    stat = (lambda f: float(f(e))) if len(e) else (lambda f: float("nan"))
    return {
        "runs": len(runs),
        "objects": int(sum(r["n_truth"] for r in runs)),
        "mean_mm": stat(np.mean),
        "median_mm": stat(np.median),
        "p90_mm": stat(lambda a: np.percentile(a, 90)),
        "max_mm": stat(np.max),
        "missed": int(sum(r["missed"] for r in runs)),
        "no_estimate": int(sum(1 for r in runs for x in r["errors"] if not np.isfinite(x))),
        "extra": int(sum(r["extra"] for r in runs)),
        "runs_with_warnings": int(sum(1 for r in runs if r["warnings"])),
        "runtime_s": float(np.median([r["runtime_s"] for r in runs])) if runs else float("nan"),
        **_nees_summary([x for r in runs for x in r.get("nees", []) if np.isfinite(x)]),
    }


def _nees_summary(nees: list[float]) -> dict[str, Any]:
    """The NEES of the objects found within the gate: how many, the median (2.37 where the covariance is calibrated:
    a chi-square's on 3 degrees of freedom) and the share beyond the 95 % ellipsoid (5 % calibrated)."""
    if not nees:
        return {"nees_objects": 0, "nees_median": float("nan"), "beyond_95": float("nan")}
    a = np.array(nees)
    return {"nees_objects": len(a), "nees_median": float(np.median(a)), "beyond_95": float(np.mean(a > NEES_95))}


def run_real(
    folder: str | Path | None = None,
    *,
    methods: tuple[str, ...] = tuple(RUNS),
    subset_size: int = 3,
    reach: float = REACH_M,
    image_size: tuple[int, int] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run the benchmark; returns a JSON-ready dict (results per method: ``all`` views and ``subsets``).

    With ``workers`` (local processes) or ``scheduler`` (a running Dask cluster) the runs are spread over
    Dask (:func:`monovisual3d.batch.spread.spread_map`); the errors are the same. ``image_size`` (width, height),
    pixels: the images' size, when not the one the loader infers from the principal point and the boxes
    (:func:`~monovisual3d.io.lfd.session_from_lfd`); the loader's warnings are said once, here.
    """
    from ..batch.spread import check_spread, spread_map

    methods = tuple(run for m in methods for run in RUN_ALIASES.get(m, (m,)))
    unknown = sorted(set(methods) - set(RUNS))
    if unknown:
        raise InputError(f"--methods: unknown {unknown[0]!r}, expected some of {[*RUNS, *RUN_ALIASES]}")
    check_spread(workers, scheduler)
    path = resolve_folder(folder)
    session, _ = read_lfd(path, image_size=image_size)  # the truth too: a bad gt.npy is one line here, not in a worker
    n = len(session.views)
    if not 1 <= subset_size <= n:
        raise InputError(f"subset_size: got {subset_size}, expected 1 to the {n} views of {one_line(str(path))}")
    sets = view_sets(n, subset_size)
    items = [(str(path), m, v, float(reach), image_size) for m in methods for v in sets]

    def tick(i: int, _: Any) -> None:
        if progress is not None:
            progress(f"{items[i][1]} views {','.join(map(str, items[i][2]))}")

    measured = spread_map(measure, items, workers=workers, scheduler=scheduler, progress=tick)
    results = {m: _per_method([r for item, r in zip(items, measured) if item[1] == m]) for m in methods}
    spread = None if not workers and scheduler is None else {"workers": workers, "scheduler": scheduler}
    return {
        "benchmark": "real",
        "data": str(path),
        "views": n,
        "subset_size": subset_size,
        "subsets": len(sets) - 1,
        "reach_m": reach,
        "image_size": [session.camera.width, session.camera.height],
        "size_range_m": list(SIZE_RANGE_M),
        "runs": {m: {"method": RUNS[m][0], **RUNS[m][1]} for m in methods},
        "gate": "errors over all Hungarian pairs; missed: no estimate within the true volume-equivalent radius (>= 20 mm)",
        "machine": machine_metadata(),
        "spread": spread,
        "results": results,
        "lfd_published": LFD_PUBLISHED,
    }


def _per_method(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """One method's runs (all views first, then the subsets) summarised, with the all-view error per object (NaN: none)
    and, per object over the subsets, :func:`per_object`."""
    return {
        "all": summarise(runs[:1]),
        "subsets": summarise(runs[1:]),
        "per_object_all_mm": [1e3 * x for x in runs[0]["errors"]],
        "per_object_subsets": per_object(runs[1:]),
    }


def per_object(runs: list[dict[str, Any]]) -> list[dict[str, float | int]]:
    """Per true object (in the truth's order) over ``runs``: the mean and p90 of its error (mm; NaN when no run had an
    estimate for it) and the runs without one (``no_estimate``): which objects set a method's pooled figures."""
    if not runs:
        return []
    e = 1e3 * np.array([r["errors"] for r in runs], dtype=float)  # (runs, objects), NaN: no estimate
    out: list[dict[str, float | int]] = []
    for column in e.T:
        seen = column[np.isfinite(column)]
        out.append(
            {
                "mean_mm": float(np.mean(seen)) if len(seen) else float("nan"),
                "p90_mm": float(np.percentile(seen, 90)) if len(seen) else float("nan"),
                "no_estimate": int(len(column) - len(seen)),
            }
        )
    return out


def format_markdown(results: dict[str, Any]) -> str:
    """The benchmark's table (Markdown): per method, all views and the subsets, beside LfD's published figures."""
    m = results["machine"]
    k, n = results["subset_size"], results["views"]
    lines = [
        f"Data: {results['data']} ({n} views, {'x'.join(map(str, results['image_size']))} images); reach {results['reach_m']:g} m; {results['gate']}. "
        f"Machine: {m['cpu']}, {m['cores']} cores; {m['date_utc'][:10]}, load average {m.get('load_average_1m', float('nan')):.1f}",
        "",
        f"| method | {n} views: mean mm | max mm | missed | {k}-view subsets ({results['subsets']}): mean mm | median mm | "
        "p90 mm | max mm | missed (no estimate) | runtime s (median) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]

    def f(v: Any) -> str:
        return "-" if v is None or (isinstance(v, float) and np.isnan(v)) else f"{v:.1f}"

    for name, r in results["results"].items():
        a, s = r["all"], r["subsets"]
        lines.append(
            f"| {name} | {f(a['mean_mm'])} | {f(a['max_mm'])} | {a['missed']}/{a['objects']} | {f(s['mean_mm'])} | "
            f"{f(s['median_mm'])} | {f(s['p90_mm'])} | {f(s['max_mm'])} | {s['missed']}/{s['objects']} ({s['no_estimate']}) | "
            f"{s['runtime_s']:.2f} |"
        )
    lfd = results["lfd_published"]
    lines.append(
        f"| LfD, given association (published code; quoted) | {f(lfd['all']['mean_mm'])} | - | - | "
        f"{f(lfd['subsets']['mean_mm'])} | - | {f(lfd['subsets']['p90_mm'])} | - | - | - |"
    )
    covered = [
        f"{name} {r['subsets']['nees_median']:.1f}, {r['subsets']['beyond_95']:.0%} ({r['subsets']['nees_objects']} objects)"
        for name, r in results["results"].items()
        if r["subsets"].get("nees_objects")
    ]
    if covered:
        lines += [
            "",
            f"Covariance of the objects found within the gate, {k}-view subsets: median NEES, share beyond the 95 % "
            f"ellipsoid (calibrated: 2.37, 5 %): {'; '.join(covered)}",
        ]
    return "\n".join(lines) + "\n"


def to_json(results: dict[str, Any]) -> str:
    """The results as JSON text, non-finite numbers (a method that found nothing) as ``null``."""

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not np.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v

    return json.dumps(clean(results), indent=2, allow_nan=False)
