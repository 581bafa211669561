"""The posterior snapshots keep their axis labels inside the canvas and explain what they draw in a legend."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from monovisual3d.figures.posterior import plot_posterior_snapshots  # noqa: E402
from monovisual3d.grid import VoxelGrid  # noqa: E402
from monovisual3d.sim.scenes import default_camera, paper_scene, scene_target  # noqa: E402
from monovisual3d.sim.viewpoints import paper_poses  # noqa: E402


@pytest.fixture(scope="module")
def posterior_figure():
    scene = paper_scene()
    grid = VoxelGrid.from_bounds([0.2, -0.6, 0.0], [1.4, 0.6, 1.2], 0.1)
    rng = np.random.default_rng(0)
    history = [rng.random(grid.n_cells) for _ in range(3)]
    return plot_posterior_snapshots(
        grid,
        history,
        truth_centres=scene.centres,
        truth_radii=scene.radii,
        camera=default_camera(),
        poses=paper_poses(scene_target(scene)),
        suptitle="posterior",
    )


def _labels_inside(fig) -> list[str]:
    """Axis labels of every 3D panel that reach outside the figure canvas (pixels)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    W, H = fig.canvas.get_width_height()
    out = []
    for ax in fig.axes:
        if ax.name != "3d":
            continue
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            bb = axis.label.get_window_extent(renderer)
            if bb.x0 < 0 or bb.y0 < 0 or bb.x1 > W or bb.y1 > H:
                out.append(axis.label.get_text())
    return out


def test_posterior_snapshots_keep_axis_labels_on_the_canvas(posterior_figure) -> None:
    fig = posterior_figure
    assert _labels_inside(fig) == []
    for ax in fig.axes:
        if ax.name == "3d":
            assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == ["x (m)", "y (m)", "z (m)"]


def test_posterior_snapshots_have_a_legend_of_cells_fruit_and_cameras(posterior_figure) -> None:
    (legend,) = posterior_figure.legends
    texts = [t.get_text() for t in legend.get_texts()]
    assert texts == ["cells with p >= 0.1 max(p), coloured by p / max(p)", "true fruit", "camera views (frusta)"]
