"""The reproduction report: the template's placeholders, the rendered text and its number formats.

The runs are hand-made (estimates = truth + a fixed offset), so these tests need no filter run.
"""

from __future__ import annotations

import importlib
import math
import re
from pathlib import Path

import pytest

from monovisual3d.experiments.reproduce import ReproduceConfig, ReproduceResult, ghost_table, render_report
from monovisual3d.experiments.reproduce.aggregate import RunRecord, record_run
from monovisual3d.experiments.reproduce.report import TEMPLATE_NAME, report_fields, report_template
from monovisual3d.methods.paper.engine.params import KERNELS
from monovisual3d.methods.paper.kmeans import CENTRES
from monovisual3d.result import DetectedObject
from monovisual3d.sim.scene import Scene
from monovisual3d.sim.scenes import default_camera, paper_scene, random_scene

TIMING = {"paper scene experiments": 1.0, "ghost study": 2.0, "figures": 0.0, "total": 3.0}


def _objects(scene: Scene, offset_m: float) -> list[DetectedObject]:
    return [DetectedObject(position=c + [offset_m, 0.0, 0.0], score=1.0, radius=r) for c, r in zip(scene.centres, scene.radii)]


def _paper_runs(cfg: ReproduceConfig, scene: Scene, experiment: str, seed: int | None) -> list[RunRecord]:
    out = []
    thresholds = sorted({cfg.keep_threshold, *cfg.thresholds})
    for order in cfg.orderings or ():
        for i, kernel in enumerate(KERNELS):
            for thr in thresholds:
                centres = CENTRES if math.isclose(thr, cfg.keep_threshold) else ("weighted",)
                for centre in centres:
                    objs = _objects(scene, 0.004 + 0.002 * i)
                    out.append(record_run(experiment, "paper", kernel, centre, thr, order, seed, scene, objs, off_fruit_mass=0.5))
        if cfg.bayes:
            out.append(record_run(experiment, "bayes", "-", "-", math.nan, order, seed, scene, _objects(scene, 0.0003)))
    return out


def _result(cfg: ReproduceConfig, files: dict[str, Path] | None = None) -> ReproduceResult:
    """A ReproduceResult with hand-made runs: paper method 4 mm (square) / 6 mm (Gaussian) off, bayes 0.3 mm off."""
    scene = paper_scene()
    records = _paper_runs(cfg, scene, "noise-free", None) + _paper_runs(cfg, scene, "noisy", cfg.seed)
    for n in cfg.ghost_counts:
        sc = random_scene(n, rng=n)
        for kernel in KERNELS:
            records.append(
                record_run("ghost", "paper", kernel, "weighted", cfg.keep_threshold, (0, 1, 2), n, sc, _objects(sc, 0.01))
            )
        if cfg.bayes:
            records.append(record_run("ghost", "bayes", "-", "-", math.nan, (0, 1, 2), n, sc, _objects(sc, 0.0003)))
    return ReproduceResult(cfg, records, Path("report.md"), dict(files or {}), 3.0, [])


def _render(result: ReproduceResult) -> str:
    return render_report(result, paper_scene(), default_camera(), TIMING, result.config.orderings or ())


@pytest.fixture(scope="module")
def quick_result() -> ReproduceResult:
    return _result(ReproduceConfig.quick_config(figures=False), {"errors_boxplot": Path("/x/errors_boxplot.png")})


def test_template_ships_as_package_data() -> None:
    # importlib: the attribute monovisual3d.experiments.reproduce is the function, the package is in sys.modules
    pkg = importlib.import_module("monovisual3d.experiments.reproduce")
    assert (Path(pkg.__file__).parent / TEMPLATE_NAME).is_file()
    text = report_template().template
    assert text.startswith("# Reproduction of MonoVisual3DFilter's simulation experiments\n")


def test_fields_fill_exactly_the_template_placeholders(quick_result: ReproduceResult) -> None:
    template = report_template()
    assert template.is_valid()
    wanted = set(template.get_identifiers())
    fields = report_fields(quick_result, paper_scene(), default_camera(), TIMING, quick_result.config.orderings or ())
    assert wanted == set(fields), (wanted - set(fields), set(fields) - wanted)
    assert all(isinstance(v, str) for v in fields.values())


@pytest.mark.parametrize(
    "cfg",
    [
        ReproduceConfig.quick_config(figures=False),
        ReproduceConfig.quick_config(figures=False, bayes=False, orderings=((0, 1, 2), (0, 2, 1)), quick=False),
    ],
    ids=["quick", "no-bayes-shared-first-view"],
)
def test_rendered_report_has_no_leftover_markers(cfg: ReproduceConfig) -> None:
    text = _render(_result(cfg))
    assert "$" not in text
    assert not re.search(r"\{[A-Za-z_]\w*\}", text), re.search(r".{40}\{[A-Za-z_]\w*\}.{40}", text)
    assert text.endswith("Raw per-run numbers (estimates, errors, settings) are in `results.json`.\n")
    assert ("Quick mode" in text) == cfg.quick
    assert ("bayes (reference)" in text) == cfg.bayes
    if cfg.orderings and cfg.orderings[0][0] == cfg.orderings[1][0]:
        assert "give identical estimates (noise-free and noisy runs)" in text
    else:
        assert "No two orderings in this run start with the same view" in text


def test_report_quotes_the_measured_numbers(quick_result: ReproduceResult) -> None:
    text = _render(quick_result)
    # square kernel 4 mm off, Gaussian 6 mm off in every run; bayes 0.3 mm
    assert "| Euclidean error, mean (mm) | 4.00 | 4.00 | 6.00 | 6.00 | 0.30 |" in text
    assert "lowest mean Euclidean error: square/weighted (4.0 mm)" in text
    assert "**30 mm cells** (64,000 cells;" in text
    assert "Orderings: 2 (1-2-3, 2-3-1)." in text
    assert "the mean error is 4.0 mm and 6.0 mm instead of the paper's < 10 mm." in text


def test_ghost_table_prints_sub_millimetre_errors_with_two_decimals(quick_result: ReproduceResult) -> None:
    table = ghost_table(quick_result)
    rows = [line for line in table.splitlines() if re.match(r"\| \d+ \|", line)]
    assert len(rows) == len(quick_result.config.ghost_counts)
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[2] == "10.0 / 10.0"  # paper square: 10 mm off
        assert cells[8] == "0.30 / 0.30"  # bayes: 0.3 mm off, not "0.3 / 0"


def test_figures_section_lists_only_written_figures(quick_result: ReproduceResult) -> None:
    text = _render(quick_result)
    assert "## Figures" in text and "](errors_boxplot.png)" in text
    assert "posterior_square.png" not in text
    no_figures = _result(ReproduceConfig.quick_config(figures=False), {"results": Path("results.json")})
    assert "## Figures" not in _render(no_figures)


def test_missing_field_is_an_error(quick_result: ReproduceResult) -> None:
    fields = report_fields(quick_result, paper_scene(), default_camera(), TIMING, quick_result.config.orderings or ())
    del fields["ghost_table"]
    with pytest.raises(KeyError, match="ghost_table"):
        report_template().substitute(fields)
