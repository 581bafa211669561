"""The reproduction's figures (matplotlib, extra ``[viz]``), drawn with :mod:`monovisual3d.figures`.

Every figure has a title, axis labels with units and a legend of what it draws.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ... import figures as viz
from ...camera import Camera
from ...grid import VoxelGrid
from ...sim.scene import Scene
from .aggregate import ReproduceResult, select
from .config import NOISE_FREE, NOISY, PAPER_LABELS, PAPER_MAX_ERROR_M

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: Captions of the figures in the report, by key of :attr:`ReproduceResult.files`, in the report's order.
CAPTIONS: dict[str, str] = {
    "errors_boxplot": "Euclidean error per configuration (log scale), noise-free and noisy; the dotted line is the paper's 10 mm claim.",
    "posterior_square": "Posterior after each view, square kernel (cells >= threshold x max, coloured by p / max p; green: true spheres; blue: cameras).",
    "posterior_gaussian": "Posterior after each view, Gaussian kernel.",
    "scene_paper": "The paper scene with the paper method's estimates (red crosses) and the true spheres (green).",
    "scene_bayes": "The same with the bayes method (red dashed: estimated spheres with their radii).",
    "ghost_study": "Mean Euclidean error against the number of fruit.",
}


def _labels(result: ReproduceResult) -> list[str]:
    return list(PAPER_LABELS) + (["bayes"] if result.config.bayes else [])


def errors_boxplot(result: ReproduceResult) -> Figure:
    """Box plots of the Euclidean error (mm) per configuration, one panel per paper-scene experiment."""
    panels = {e: {lab: 1e3 * result.aggregate(e, lab).errors_m for lab in _labels(result)} for e in (NOISE_FREE, NOISY)}
    return viz.plot_error_boxes(
        panels,
        title="Euclidean error per configuration (paper scene, all orderings"
        + (", all seeds)" if result.config.seeds > 1 else ")"),
        xlabel="configuration (kernel/centre, or method)",
        log=True,
        reference_mm=1e3 * PAPER_MAX_ERROR_M,
        reference_label="paper: max < 10 mm",
    )


def posterior_figure(
    result: ReproduceResult,
    kernel: str,
    grid: VoxelGrid,
    history: list[NDArray[np.float64]],
    scene: Scene,
    camera: Camera,
    poses: NDArray[np.float64],
    first: tuple[int, ...],
) -> Figure:
    """The paper filter's posterior after each view (noise-free, first ordering), as the paper's Figs. 7-8."""
    sf = result.config.sigma_fraction_noise_free
    return viz.plot_posterior_snapshots(
        grid,
        history,
        truth_centres=scene.centres,
        truth_radii=scene.radii,
        camera=camera,
        poses=poses,
        threshold=result.config.keep_threshold,
        suptitle=f"paper method, {kernel} kernel"
        + (f" (sigma = {sf:g} x box size)" if kernel == "gaussian" else "")
        + f", noise-free, views in order {tuple(i + 1 for i in first)}",
    )


def scene_figure(
    result: ReproduceResult,
    label: str,
    method: str,
    scene: Scene,
    camera: Camera,
    poses: NDArray[np.float64],
    first: tuple[int, ...],
) -> Figure | None:
    """The paper scene with one configuration's estimates (noise-free, first ordering); None without such a run."""
    recs = select(result.records, NOISE_FREE, label, result.config.keep_threshold, ordering=first)
    if not recs:
        return None
    r = recs[0]
    return viz.plot_scene(
        scene.centres,
        scene.radii,
        estimates=r.estimates,
        estimate_radii=r.estimate_radii,
        camera=camera,
        poses=poses,
        title=f"paper scene, noise-free: {method} method ({label}), "
        f"mean error {1e3 * r.metrics.euclidean_mean:.1f} mm, {r.metrics.misses} missed",
    )


def ghost_figure(result: ReproduceResult) -> Figure:
    """Mean Euclidean error (mm) against the number of fruit in the ghost study."""
    counts = list(result.config.ghost_counts)
    curves = {}
    for label in ("square/weighted", "gaussian/weighted") + (("bayes",) if result.config.bayes else ()):
        curves[label if label == "bayes" else f"paper {label}"] = [
            1e3 * result.aggregate("ghost", label, n_fruit=n).euclidean_mean for n in counts
        ]
    scenes = result.config.ghost_scenes
    return viz.plot_curves(
        counts,
        curves,
        xlabel="fruit in the scene (count)",
        ylabel="mean Euclidean error (mm)",
        title=f"Ghost study (noise-free, {scenes} random scene{'s' if scenes > 1 else ''} per count)",
        log=True,
    )


def write_figures(
    out: Path,
    result: ReproduceResult,
    scene: Scene,
    camera: Camera,
    poses: NDArray[np.float64],
    orderings: Sequence[tuple[int, ...]],
    snapshots: dict[str, tuple[VoxelGrid, list[NDArray[np.float64]]]],
) -> dict[str, Path]:
    """Draw every figure of the report into ``out``; returns the paths by key of :data:`CAPTIONS`."""
    files: dict[str, Path] = {}
    files["errors_boxplot"] = viz.save_figure(errors_boxplot(result), out / "errors_boxplot.png")
    first = orderings[0]
    P = poses[list(first)]
    for kernel, (grid, history) in snapshots.items():
        fig = posterior_figure(result, kernel, grid, history, scene, camera, P, first)
        files[f"posterior_{kernel}"] = viz.save_figure(fig, out / f"posterior_{kernel}.png")
    for label, method in (("gaussian/weighted", "paper"), ("bayes", "bayes")):
        fig = scene_figure(result, label, method, scene, camera, P, first)
        if fig is not None:
            files[f"scene_{method}"] = viz.save_figure(fig, out / f"scene_{method}.png")
    files["ghost_study"] = viz.save_figure(ghost_figure(result), out / "ghost_study.png")
    return files
