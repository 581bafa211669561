"""scene.png explains itself: titles, axis labels with units, a legend that matches what is drawn, numbered fruit, nothing clipped."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from monovisual3d import Camera
from monovisual3d.figures._style import STEM_COLOUR
from monovisual3d.figures.scene import plot_scene
from monovisual3d.frames import look_at

pytest.importorskip("matplotlib")
from matplotlib.colors import to_rgba  # noqa: E402
from mpl_checks import texts_inside_figure  # noqa: E402

CAM = Camera.from_hfov(640, 480, 69.0)


def scene_with_occluders() -> Any:
    from monovisual3d.sim.scene import Leaf, Stem

    leaf = Leaf(np.array([0.55, 0.0, 0.45]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), (0.03, 0.02))
    stem = Stem(np.array([0.6, -0.1, 0.3]), np.array([0.6, 0.1, 0.6]), 0.004)
    poses = [look_at([0.2, y, 0.5], [0.6, 0.0, 0.45]) for y in (-0.1, 0.0, 0.1)]
    return plot_scene(
        [[0.6, 0.0, 0.45], [0.62, 0.05, 0.4]],
        [0.03, 0.025],
        estimates=[[0.605, 0.0, 0.45], [0.62, 0.05, 0.41]],
        estimate_radii=[0.029, 0.026],
        camera=CAM,
        poses=poses,
        occluders=[leaf, stem],
        title="two fruit",
    )


def test_scene_panels_have_titles_and_labels_with_units() -> None:
    fig = scene_with_occluders()
    ax3d, front, top = fig.axes
    assert ax3d.get_title() and ax3d.get_zlabel() == "z (m)" and ax3d.get_xlabel() == "x (m)"
    assert front.get_title().startswith("front view") and top.get_title().startswith("top view")
    for ax in (front, top):
        assert ax.get_xlabel().endswith("(m)") and ax.get_ylabel().endswith("(m)")
    assert texts_inside_figure(fig) == []


def test_scene_legend_matches_what_is_drawn() -> None:
    fig = scene_with_occluders()
    (legend,) = fig.legends
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[:2] == ["true fruit", "estimate k (centre x, size dashed; k = table row)"]
    assert "camera frustum (3D panel)" in labels and "leaf" in labels and "stem" in labels
    stem_handle = legend.legend_handles[labels.index("stem")]
    assert to_rgba(stem_handle.get_color()) == to_rgba(STEM_COLOUR)  # the stem is drawn in this colour
    stem_lines = [ln for ax in fig.axes for ln in ax.get_lines() if to_rgba(ln.get_color()) == to_rgba(STEM_COLOUR)]
    assert len(stem_lines) == 3  # in each panel
    numbers = [t.get_text() for t in fig.axes[0].texts]
    assert numbers == ["0", "1", "2"] and all(t.get_fontsize() >= 10 for t in fig.axes[0].texts)


def test_scene_legend_leaves_out_what_is_not_drawn() -> None:
    fig = plot_scene([[0.6, 0.0, 0.45]], [0.03], estimates=[[0.61, 0.0, 0.45]])
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["true fruit", "estimate k (centre; k = table row)"]


def test_estimates_are_numbered_as_in_the_table_in_the_front_and_top_views() -> None:
    fig = scene_with_occluders()
    estimates = np.array([[0.605, 0.0, 0.45], [0.62, 0.05, 0.41]])
    for ax, (a, b) in zip(fig.axes[1:], ((1, 2), (1, 0))):
        numbers = {t.get_text(): t.xy for t in ax.texts}
        assert sorted(numbers) == ["0", "1"]
        for k, p in enumerate(estimates):  # number k sits on estimate k (result.objects[k], row k of the table)
            np.testing.assert_allclose(numbers[str(k)], (p[a], p[b]))


def test_legend_row_clears_the_x_labels_and_the_3d_panel_is_the_widest() -> None:
    fig = scene_with_occluders()
    fig.set_dpi(120)  # as save_figure writes it
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = fig.legends[0].get_window_extent(renderer)
    for ax in fig.axes[1:]:
        label = ax.xaxis.label.get_window_extent(renderer)
        assert label.y0 - legend.y1 >= 15.0, "the legend row (nearly) touches an x label"  # 11 px before the fix
    widths = [ax.get_position(original=True).width for ax in fig.axes]  # the room each panel is given
    assert widths[0] > 1.2 * max(widths[1:])


def test_camera_numbers_do_not_cover_the_fruit() -> None:
    from mpl_toolkits.mplot3d import proj3d

    from monovisual3d.sim.scenes import default_camera, greenhouse_scene, scene_target
    from monovisual3d.sim.viewpoints import paper_poses

    scene = greenhouse_scene(np.random.default_rng(0), camera=default_camera())
    fig = plot_scene(scene.centres, scene.radii, camera=default_camera(), poses=paper_poses(scene_target(scene)))
    fig.canvas.draw()
    ax = fig.axes[0]
    renderer = fig.canvas.get_renderer()

    def pixels(p: np.ndarray) -> np.ndarray:
        x, y, _ = proj3d.proj_transform(*p.T, ax.get_proj())
        return ax.transData.transform(np.column_stack([x, y]))

    centre = pixels(scene.centres)
    radius = np.linalg.norm(pixels(scene.centres + [0.0, 0.0, 1.0] * scene.radii[:, None]) - centre, axis=1)
    tags = [t for t in ax.texts if t.get_text().isdigit()]
    assert len(tags) == 3
    for t in tags:  # distance from each fruit's disc to the tag's box (negative: they overlap; -14 px before the fix)
        e = t.get_bbox_patch().get_window_extent(renderer)
        dx = np.maximum(np.maximum(e.x0 - centre[:, 0], 0), centre[:, 0] - e.x1)
        dy = np.maximum(np.maximum(e.y0 - centre[:, 1], 0), centre[:, 1] - e.y1)
        assert np.min(np.hypot(dx, dy) - radius) > 0, f"camera {t.get_text()}'s number covers a fruit"
