"""The Markdown report: tables and numbers measured by the run, filled into the text template ``report.md.tmpl``.

The prose lives in the template (package data, :func:`string.Template` syntax,
``${name}`` placeholders); this module only formats numbers, builds the tables
and picks the few phrases that depend on the measurements (:data:`PHRASES`).
:func:`report_fields` returns every placeholder's text, :func:`render_report`
substitutes them (a placeholder without a value is an error, not a blank).
"""

from __future__ import annotations

import math
import platform
import string
from collections.abc import Sequence
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ... import __version__
from ...camera import Camera
from ...methods.paper.engine.params import KERNELS
from ...sim.scene import Scene
from ...sim.viewpoints import PAPER_DISTANCE_M, PAPER_OFFSET_M
from .aggregate import Aggregate, ReproduceResult, RunRecord, aggregate_records, select
from .config import NOISE_FREE, NOISY, PAPER_LABELS, PAPER_MAX_ERROR_M, PAPER_TESTBED_TABLE
from .figures import CAPTIONS

#: File name of the report template, shipped next to this module.
TEMPLATE_NAME = "report.md.tmpl"

#: Phrases of the discussion chosen by what the run measured.
PHRASES: dict[str, str] = {
    "quick": "> **Quick mode**: coarse grid, one noise seed, a subset of orderings and ghost scenes. Numbers are for "
    "testing the pipeline only; run `monovisual3d reproduce` without `--quick` for the report's real numbers.",
    "centres_identical": "identical here",
    "centres_differ": "not identical here (some cells differ in weight where boxes overlap)",
    "within": "within the paper's claim (mean and max < 10 mm)",
    "mean_within": "a mean within the paper's 10 mm but not its maximum",
    "far": "still far from the paper's < 10 mm",
    "square_flat": "The square rows do not change with the threshold: ghost cells have exactly the same value as the "
    "true fruit, so no threshold separates them. ",
    "square_varies": "The square rows change little with the threshold: most ghost cells have the same value as the true fruit. ",
    "orderings_none": "No two orderings in this run start with the same view, so the grid effect cannot be isolated.",
    "orderings_same": "Orderings that start with the same view give identical estimates ({which} runs), as expected: "
    "the product over views is commutative and only the first view places the grid. ",
    "orderings_differ": "Orderings that start with the same view give different estimates, which the commutative "
    "product does not explain. ",
    "orderings_grid": "A different first view changes the grid's orientation and cell boundaries and with them which "
    "cells survive, so the error varies between first views (orderings table).",
    "single_fruit": "; with a single fruit there are no ghosts, so this is the method's own bias: the surviving region "
    "is the intersection of three cones, longer along the viewing direction and wider on its far side, and with the "
    "Gaussian kernel {off} of the clustered mass already lies outside the fruit",
    "bayes_ghost": " The `bayes` method, which scores each (position, radius) hypothesis by how well it predicts the box "
    "edges in every view and removes a fruit's boxes once it is accepted, errs by {mean} mm (max {max} mm) with recall "
    "{recall} and {fp} false positives at {n} fruit.",
}


# ---------------------------------------------------------------------- number formats
def _mm(v: float, digits: int = 1) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{1e3 * v:.{digits}f}"


def _mm_fine(v: float) -> str:
    """Millimetres with at least two significant digits below 1 mm (0.36, not 0), one decimal above."""
    return _mm(v, 2 if math.isfinite(v) and abs(1e3 * v) < 1 else 1)


def _num(v: float, digits: int = 1) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _pct(v: float) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{100 * v:.0f} %"


def _recall(a: Aggregate) -> str:
    return _num(1 - a.misses / a.n_truth, 2) if a.n_truth else "-"


def _order(order: Sequence[int]) -> str:
    return "-".join(str(i + 1) for i in order)


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] + ["---:"] * (len(header) - 1)) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


# ---------------------------------------------------------------------- tables
def configuration_table(result: ReproduceResult, experiment: str) -> str:
    """The paper's metric table (rows: metrics, columns: configurations) for one experiment, in mm."""
    labels = list(PAPER_LABELS) + (["bayes"] if result.config.bayes else [])
    aggs = [result.aggregate(experiment, lab) for lab in labels]
    thr = result.config.keep_threshold
    skipped = [sum(r.skipped_views for r in select(result.records, experiment, lab, thr)) for lab in labels]
    header = ["metric"] + [
        lab.replace("square", "Square")
        .replace("gaussian", "Gaussian")
        .replace("/weighted", " weighted")
        .replace("/geometric", " geometric")
        + (" (reference)" if lab == "bayes" else "")
        for lab in labels
    ]
    rows = [
        ["Euclidean error, mean (mm)"] + [_mm(a.euclidean_mean, 2) for a in aggs],
        ["Euclidean error, max (mm)"] + [_mm(a.euclidean_max, 1) for a in aggs],
        ["MSE (mm²)"] + [_num(1e6 * a.mse, 1) for a in aggs],
        ["RMSE (mm)"] + [_mm(a.rmse, 2) for a in aggs],
        ["MAE (mm)"] + [_mm(a.mae, 2) for a in aggs],
        ["MAPE (%)"] + [_num(a.mape, 2) for a in aggs],
        ["misses / fruit"] + [f"{a.misses} / {a.n_truth}" for a in aggs],
        ["false positives"] + [str(a.false_positives) for a in aggs],
        ["off-fruit mass of clustered cells"] + [_pct(a.off_fruit_mass) for a in aggs],
        ["views skipped by the filter"] + [str(s) if lab != "bayes" else "-" for lab, s in zip(labels, skipped)],
        ["runs"] + [str(a.runs) for a in aggs],
    ]
    return _table(header, rows)


def testbed_table() -> str:
    """The paper's testbed table, converted to mm / mm² (real robot data, for reference)."""
    header = ["metric (paper, testbed)"] + [lab.replace("/", " ") for lab in PAPER_LABELS]
    t = PAPER_TESTBED_TABLE
    rows = [
        ["Euclidean error, mean (mm)"] + [f"{1e3 * t[lab]['euclidean_mean']:.1f}" for lab in PAPER_LABELS],
        ["MSE (mm²)"] + [f"{1e6 * t[lab]['mse']:.1f}" for lab in PAPER_LABELS],
        ["RMSE (mm)"] + [f"{1e3 * t[lab]['rmse']:.1f}" for lab in PAPER_LABELS],
        ["MAE (mm)"] + [f"{1e3 * t[lab]['mae']:.1f}" for lab in PAPER_LABELS],
        ["MAPE (%)"] + [f"{t[lab]['mape']:.2f}" for lab in PAPER_LABELS],
    ]
    return _table(header, rows)


def ordering_table(result: ReproduceResult, orderings: Sequence[tuple[int, ...]]) -> str:
    """Mean Euclidean error per pose ordering (noise-free and noisy), each paper configuration."""
    header = ["experiment", "order of views"] + list(PAPER_LABELS)
    thr = result.config.keep_threshold
    rows = []
    for experiment in (NOISE_FREE, NOISY):
        for order in orderings:
            cells = []
            for lab in PAPER_LABELS:
                a = aggregate_records(select(result.records, experiment, lab, thr, ordering=tuple(order)))
                cells.append(f"{_mm(a.euclidean_mean)} ({a.misses} miss)")
            rows.append([experiment, _order(order)] + cells)
    return _table(header, rows)


def threshold_table(result: ReproduceResult) -> str:
    """Weighted-centre errors as a function of the k-means cell threshold."""
    thresholds = sorted({result.config.keep_threshold, *result.config.thresholds})
    header = ["experiment", "kernel"] + [f"keep ≥ {t:g}·max" for t in thresholds]
    rows = []
    for experiment in (NOISE_FREE, NOISY):
        for kernel in KERNELS:
            cells = []
            for t in thresholds:
                a = result.aggregate(experiment, f"{kernel}/weighted", keep_threshold=t)
                cells.append(f"{_mm(a.euclidean_mean)} mm (max {_mm_fine(a.euclidean_max)}; {a.misses} miss)")
            rows.append([experiment, kernel] + cells)
    return _table(header, rows)


def ghost_table(result: ReproduceResult) -> str:
    """Errors against the number of fruit: the paper method (both kernels) and bayes."""
    methods = [("paper square", "square/weighted"), ("paper Gaussian", "gaussian/weighted")]
    if result.config.bayes:
        methods.append(("bayes", "bayes"))
    header = ["fruit", "scenes"]
    for name, _ in methods:
        header += [f"{name}: mean / max (mm)", f"{name}: recall", f"{name}: false pos."]
    header += ["paper Gaussian: off-fruit mass"]
    rows = []
    for n in result.config.ghost_counts:
        aggs = {lab: result.aggregate("ghost", lab, n_fruit=n) for _, lab in methods}
        row = [str(n), str(aggs[methods[0][1]].runs)]
        for _, lab in methods:
            a = aggs[lab]
            row += [f"{_mm_fine(a.euclidean_mean)} / {_mm_fine(a.euclidean_max)}", _recall(a), str(a.false_positives)]
        row.append(_pct(aggs["gaussian/weighted"].off_fruit_mass))
        rows.append(row)
    return _table(header, rows)


def _verdict(ok: bool) -> str:
    return "agrees" if ok else "**disagrees**"


def _paper_facts(result: ReproduceResult) -> dict[str, Any]:
    """Per paper-scene experiment: the paper configurations' aggregates and the best of them by mean error."""
    facts: dict[str, Any] = {}
    for experiment in (NOISE_FREE, NOISY):
        aggs = {lab: result.aggregate(experiment, lab) for lab in PAPER_LABELS}
        best = min(
            PAPER_LABELS, key=lambda lab: aggs[lab].euclidean_mean if math.isfinite(aggs[lab].euclidean_mean) else math.inf
        )
        facts[experiment] = {"aggs": aggs, "best": best}
    return facts


def statements_table(result: ReproduceResult) -> tuple[str, dict[str, Any]]:
    """The paper's simulation statements next to what we measure, with a computed verdict."""
    facts = _paper_facts(result)
    gw = {e: facts[e]["aggs"]["gaussian/weighted"] for e in (NOISE_FREE, NOISY)}
    max_all = {e: max(a.euclidean_max for a in facts[e]["aggs"].values()) for e in (NOISE_FREE, NOISY)}
    b0, b1 = facts[NOISE_FREE]["best"], facts[NOISY]["best"]
    sq, ga = facts[NOISY]["aggs"]["square/weighted"], facts[NOISY]["aggs"]["gaussian/weighted"]
    rows = [
        [
            '"Under a simulated environment, the system always got a maximum error smaller than 10 mm" (Discussion)',
            f"max error, Gaussian/weighted: {_mm(gw[NOISE_FREE].euclidean_max)} mm noise-free, {_mm(gw[NOISY].euclidean_max)} mm noisy; "
            f"worst configuration: {_mm(max_all[NOISE_FREE])} / {_mm(max_all[NOISY])} mm",
            _verdict(gw[NOISE_FREE].euclidean_max < PAPER_MAX_ERROR_M and gw[NOISY].euclidean_max < PAPER_MAX_ERROR_M),
        ],
        [
            '"a mean absolute error lower than 10 mm in simulation" (Abstract; Results: "smaller than 1 cm")',
            f"MAE, Gaussian/weighted: {_mm(gw[NOISE_FREE].mae, 2)} mm noise-free, {_mm(gw[NOISY].mae, 2)} mm noisy",
            _verdict(gw[NOISE_FREE].mae < 0.010 and gw[NOISY].mae < 0.010),
        ],
        [
            'Noise-free: "using a Gaussian kernel with a weighted centre estimation was advantageous"',
            f"lowest mean Euclidean error: {b0} ({_mm(facts[NOISE_FREE]['aggs'][b0].euclidean_mean)} mm)",
            _verdict(b0 == "gaussian/weighted"),
        ],
        [
            'Noisy: "Once again, the Gaussian kernel with a weighted estimation of the spheres\' centre performed better"',
            f"lowest mean Euclidean error: {b1} ({_mm(facts[NOISY]['aggs'][b1].euclidean_mean)} mm)",
            _verdict(b1 == "gaussian/weighted"),
        ],
        [
            'Noisy: "the Gaussian kernel was more robust and accurate than the square kernel"',
            f"weighted centre: Gaussian {_mm(ga.euclidean_mean)} mm, {ga.misses} misses; square {_mm(sq.euclidean_mean)} mm, {sq.misses} misses",
            _verdict(ga.euclidean_mean < sq.euclidean_mean and ga.misses <= sq.misses),
        ],
        [
            "Testbed (real robot, OAK-1): mean Euclidean error about 20 mm (table below)",
            "not reproduced: real-robot data; our experiments are the simulation ones",
            "n/a",
        ],
    ]
    return _table(["paper states", "we measure", "verdict"], rows), facts


# ---------------------------------------------------------------------- discussion fields
def _same_first_view_identical(result: ReproduceResult, experiment: str) -> bool | None:
    """Whether paper-method runs that differ only in the order of views after the first give the same estimates.

    None when no two orderings share a first view.
    """
    groups: dict[tuple[Any, ...], list[RunRecord]] = {}
    for r in result.records:
        if r.experiment == experiment and r.method == "paper":
            groups.setdefault((r.label, r.keep_threshold, r.seed, r.ordering[0]), []).append(r)
    pairs = [g for g in groups.values() if len(g) > 1]
    if not pairs:
        return None

    def rows(r: RunRecord) -> NDArray[np.float64]:
        return r.estimates[np.lexsort(r.estimates.T[::-1])] if len(r.estimates) else r.estimates

    return all(
        g[0].estimates.shape == r.estimates.shape and np.allclose(rows(g[0]), rows(r), rtol=0, atol=1e-9)
        for g in pairs
        for r in g[1:]
    )


def _centre_fields(facts: dict[str, Any]) -> dict[str, str]:
    """The noise-free aggregates quoted by the ghosts and centre bullets."""
    nf = facts[NOISE_FREE]["aggs"]
    sq, ga, sq_geo, ga_geo = nf["square/weighted"], nf["gaussian/weighted"], nf["square/geometric"], nf["gaussian/geometric"]
    same = sq.errors_m.shape == sq_geo.errors_m.shape and np.allclose(sq.errors_m, sq_geo.errors_m, atol=1e-9)
    return {
        "nf_square_off_fruit": _pct(sq.off_fruit_mass),
        "nf_gauss_off_fruit": _pct(ga.off_fruit_mass),
        "k": str(sq.n_truth // max(sq.runs, 1)),
        "nf_square_misses": str(sq.misses),
        "nf_gauss_misses": str(ga.misses),
        "nf_n_truth": str(sq.n_truth),
        "nf_square_mean_mm": _mm(sq.euclidean_mean),
        "nf_gauss_mean_mm": _mm(ga.euclidean_mean),
        "nf_gauss_geometric_mean_mm": _mm(ga_geo.euclidean_mean),
        "square_centres_same": PHRASES["centres_identical" if same else "centres_differ"],
        "gauss_weighted_better": "better" if ga.euclidean_mean < ga_geo.euclidean_mean else "not better",
    }


def _threshold_fields(result: ReproduceResult) -> dict[str, str]:
    """The best threshold of the sweep per experiment, and whether the square rows depend on the threshold."""
    thresholds = sorted({result.config.keep_threshold, *result.config.thresholds})
    parts = []
    for experiment in (NOISE_FREE, NOISY):
        vals = {t: result.aggregate(experiment, "gaussian/weighted", keep_threshold=t) for t in thresholds}
        t_best = min(thresholds, key=lambda t: vals[t].euclidean_mean if math.isfinite(vals[t].euclidean_mean) else math.inf)
        a = vals[t_best]
        if a.euclidean_mean < PAPER_MAX_ERROR_M and a.euclidean_max < PAPER_MAX_ERROR_M:
            verdict = PHRASES["within"]
        else:
            verdict = PHRASES["mean_within" if a.euclidean_mean < PAPER_MAX_ERROR_M else "far"]
        parts.append(
            f"{experiment}: {_mm(a.euclidean_mean)} mm (max {_mm(a.euclidean_max)} mm, {a.misses} misses) at {t_best:g} x max, {verdict}"
        )
    square_flat = all(
        math.isclose(
            result.aggregate(e, "square/weighted", keep_threshold=t).euclidean_mean,
            result.aggregate(e, "square/weighted", keep_threshold=thresholds[0]).euclidean_mean,
            rel_tol=1e-9,
        )
        for e in (NOISE_FREE, NOISY)
        for t in thresholds
    )
    return {
        "best_thresholds": "; ".join(parts),
        "square_threshold_sentence": PHRASES["square_flat" if square_flat else "square_varies"],
    }


def _orderings_discussion(result: ReproduceResult) -> str:
    same = {e: _same_first_view_identical(result, e) for e in (NOISE_FREE, NOISY)}
    if same[NOISE_FREE] is None:
        return PHRASES["orderings_none"]
    ident = [e for e in (NOISE_FREE, NOISY) if same[e]]
    first = PHRASES["orderings_same"].format(which=" and ".join(ident)) if ident else PHRASES["orderings_differ"]
    return first + PHRASES["orderings_grid"]


def _noise_and_ghost_fields(result: ReproduceResult, facts: dict[str, Any]) -> dict[str, str]:
    """The noisy-run numbers and the ghost-study bullet's numbers and clauses."""
    nn = facts[NOISY]["aggs"]
    counts = list(result.config.ghost_counts)
    n0, n1 = counts[0], counts[-1]
    g = {n: result.aggregate("ghost", "gaussian/weighted", n_fruit=n) for n in (n0, n1)}
    q = {n: result.aggregate("ghost", "square/weighted", n_fruit=n) for n in (n0, n1)}
    bayes = ""
    if result.config.bayes:
        b = result.aggregate("ghost", "bayes", n_fruit=n1)
        bayes = PHRASES["bayes_ghost"].format(
            mean=_mm(b.euclidean_mean), max=_mm(b.euclidean_max), recall=_recall(b), fp=b.false_positives, n=n1
        )
    return {
        "noisy_square_mean_mm": _mm(nn["square/weighted"].euclidean_mean),
        "noisy_square_misses": str(nn["square/weighted"].misses),
        "noisy_gauss_mean_mm": _mm(nn["gaussian/weighted"].euclidean_mean),
        "noisy_gauss_misses": str(nn["gaussian/weighted"].misses),
        "ghost_n0": str(n0),
        "ghost_n1": str(n1),
        "ghost_square_mean_mm_n0": _mm(q[n0].euclidean_mean),
        "ghost_gauss_mean_mm_n0": _mm(g[n0].euclidean_mean),
        "single_fruit_clause": PHRASES["single_fruit"].format(off=_pct(g[n0].off_fruit_mass)) if n0 == 1 else "",
        "ghost_square_mean_mm_n1": _mm(q[n1].euclidean_mean),
        "ghost_square_recall_n1": _recall(q[n1]),
        "ghost_gauss_mean_mm_n1": _mm(g[n1].euclidean_mean),
        "ghost_gauss_recall_n1": _recall(g[n1]),
        "ghost_gauss_off_fruit_n0": _pct(g[n0].off_fruit_mass),
        "ghost_gauss_off_fruit_n1": _pct(g[n1].off_fruit_mass),
        "bayes_ghost_clause": bayes,
    }


# ---------------------------------------------------------------------- setup and assembly
def _setup_fields(result: ReproduceResult, scene: Scene, camera: Camera, orderings: Sequence[tuple[int, ...]]) -> dict[str, str]:
    """The numbers of the setup section: scene, views, noise, grid and kernel."""
    cfg = result.config
    return {
        "n_spheres": str(len(scene.fruits)),
        "diameters_mm": ", ".join(f"{2e3 * r:.0f}" for r in scene.radii),
        "width": str(camera.width),
        "height": str(camera.height),
        "hfov_deg": f"{math.degrees(2 * math.atan(camera.width / (2 * camera.fx))):.0f}",
        "distance_m": str(PAPER_DISTANCE_M),
        "offset_m": str(PAPER_OFFSET_M),
        "n_orderings": str(len(orderings)),
        "orderings": ", ".join(_order(o) for o in orderings),
        "box_sigma": f"{cfg.box_sigma:g}",
        "drop_pct": f"{100 * cfg.drop_probability:g}",
        "n_seeds": str(cfg.seeds),
        "seed_list": ", ".join(str(s) for s in range(cfg.seed, cfg.seed + cfg.seeds)),
        "side_m": f"{2 * cfg.reach:g}",
        "resolution_mm": f"{1e3 * cfg.resolution:g}",
        "n_cells": f"{int(math.ceil(2 * cfg.reach / cfg.resolution - 1e-9)) ** 3:,}",
        "sigma_noise_free": f"{cfg.sigma_fraction_noise_free:g}",
        "sigma_noisy": f"{cfg.sigma_fraction_noisy:.3g}",
        "keep_threshold": f"{cfg.keep_threshold:g}",
        "ghost_scenes": str(cfg.ghost_scenes),
        "ghost_seed": str(cfg.ghost_seed),
    }


def _figures_and_notes(result: ReproduceResult) -> dict[str, str]:
    """The figures section (only the figures written, in :data:`~.figures.CAPTIONS` order) and the run's notes."""
    figures = "".join(
        f"![{caption}]({result.files[key].name})\n\n*{caption}*\n\n" for key, caption in CAPTIONS.items() if key in result.files
    )
    return {
        "figures": "## Figures\n\n" + figures if figures else "",
        "notes": "".join(f"> {note}\n\n" for note in result.notes),
    }


def report_fields(
    result: ReproduceResult, scene: Scene, camera: Camera, timing: dict[str, float], orderings: Sequence[tuple[int, ...]]
) -> dict[str, str]:
    """The text of every placeholder of the report template, from the run's measurements."""
    statements, facts = statements_table(result)
    return {
        "quick_note": PHRASES["quick"] + "\n\n" if result.config.quick else "",
        "version": __version__,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "total_s": f"{timing['total']:.0f}",
        "statements_table": statements,
        "testbed_table": testbed_table(),
        "noise_free_table": configuration_table(result, NOISE_FREE),
        "noisy_table": configuration_table(result, NOISY),
        "ordering_table": ordering_table(result, orderings),
        "threshold_table": threshold_table(result),
        "ghost_table": ghost_table(result),
        "orderings_discussion": _orderings_discussion(result),
        "runtime_table": _table(["stage", "seconds"], [[k, f"{v:.1f}"] for k, v in timing.items()]),
        **_setup_fields(result, scene, camera, orderings),
        **_centre_fields(facts),
        **_threshold_fields(result),
        **_noise_and_ghost_fields(result, facts),
        **_figures_and_notes(result),
    }


def report_template() -> string.Template:
    """The report's text template (package data ``report.md.tmpl``)."""
    text = resources.files(__package__).joinpath(TEMPLATE_NAME).read_text(encoding="utf-8")
    return string.Template(text)


def render_report(
    result: ReproduceResult, scene: Scene, camera: Camera, timing: dict[str, float], orderings: Sequence[tuple[int, ...]]
) -> str:
    """The Markdown report (tables measured by this run, figures linked by relative path).

    Raises
    ------
    KeyError
        When the template has a placeholder that :func:`report_fields` does not fill.
    """
    return report_template().substitute(report_fields(result, scene, camera, timing, orderings))
