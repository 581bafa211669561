"""Matplotlib figures explain themselves: titles, axis labels with units, legends that match what is drawn, nothing clipped."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from monovisual3d import Camera
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.viz import STEM_COLOUR, label_positions, plot_error_boxes, plot_scene, plot_view

pytest.importorskip("matplotlib")
from matplotlib.colors import to_rgba  # noqa: E402

CAM = Camera.from_hfov(640, 480, 69.0)


def texts_inside_figure(fig: Any) -> list[str]:
    """Texts (titles, axis labels, legend entries) whose drawn extent leaves the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    out = []
    texts = list(fig.texts) + ([fig._suptitle] if fig._suptitle is not None else [])
    for ax in fig.axes:
        texts += [ax.title, ax.xaxis.label, ax.yaxis.label] + ([ax.zaxis.label] if hasattr(ax, "zaxis") else [])
        if ax.get_legend() is not None:
            texts += list(ax.get_legend().get_texts())
    for leg in fig.legends:
        texts += list(leg.get_texts())
    for t in texts:
        if not t.get_text() or not t.get_visible():
            continue
        e = t.get_window_extent(renderer)
        if e.x0 < box.x0 - 1 or e.y0 < box.y0 - 1 or e.x1 > box.x1 + 1 or e.y1 > box.y1 + 1:
            out.append(t.get_text())
    return out


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
    assert labels[:2] == ["true fruit", "estimate (centre x, size dashed)"]
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
    assert labels == ["true fruit", "estimate (centre)"]


def test_view_figure_has_title_axes_in_pixels_and_legend() -> None:
    img = np.full((480, 640, 3), 200, dtype=np.uint8)
    boxes = [[100, 100, 160, 160], [150, 105, 200, 170], [400, 300, 420, 310]]
    fig = plot_view(img, boxes, false_positive=[False, False, True], regions={"fruit": (220, 30, 30)}, title="view 1")
    (ax,) = fig.axes
    assert ax.get_title() == "view 1" and ax.get_xlabel() == "u (px)" and ax.get_ylabel() == "v (px)"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[0] == "fruit" and labels[1].startswith("detection box") and labels[2] == "false positive box"
    assert [t.get_text() for t in ax.texts] == ["0", "1", "2"]
    assert texts_inside_figure(fig) == []


def test_box_labels_do_not_overlap() -> None:
    rng = np.random.default_rng(3)
    xy1 = rng.uniform([50, 50], [550, 400], size=(25, 2))
    boxes = np.column_stack([xy1, xy1 + rng.uniform(10, 60, size=(25, 2))])
    sizes = np.tile([14.0, 16.0], (25, 1))
    pos = label_positions(boxes, sizes, (640, 480))
    rects = np.column_stack([pos, pos + sizes])
    assert np.all(rects[:, :2] >= 0) and np.all(rects[:, 2] <= 640) and np.all(rects[:, 3] <= 480)
    for a in range(len(rects)):
        for b in range(a + 1, len(rects)):
            dx = min(rects[a, 2], rects[b, 2]) - max(rects[a, 0], rects[b, 0])
            dy = min(rects[a, 3], rects[b, 3]) - max(rects[a, 1], rects[b, 1])
            assert dx <= 1e-9 or dy <= 1e-9, (a, b)
    # each label touches its own box (it names that box)
    for (x1, y1, x2, y2), (lx0, ly0, lx1, ly1) in zip(boxes, rects):
        assert lx1 >= x1 - 14 - 1e-9 and lx0 <= x2 + 1e-9 and ly1 >= y1 - 1e-9 and ly0 <= y2 + 1e-9


def test_error_boxes_have_labels() -> None:
    fig = plot_error_boxes({"a": [1.0, 2.0], "b": [2.0, 3.0]}, title="errors", reference_mm=2.5, reference_label="paper")
    (ax,) = fig.axes
    assert ax.get_ylabel() == "Euclidean error (mm)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "quartiles, whiskers 1.5 IQR",
        "median",
        "mean",
        "outlier",
        "paper",
    ]
    assert texts_inside_figure(fig) == []


def test_bad_inputs() -> None:
    with pytest.raises(InputError, match=r"label_sizes: expected 2 sizes, got 1"):
        label_positions([[0, 0, 1, 1], [2, 2, 3, 3]], [[1, 1]], (10, 10))
    with pytest.raises(InputError, match=r"image: expected shape \(H, W, 3\), got \(4, 4\)"):
        plot_view(np.zeros((4, 4)), [])
    with pytest.raises(InputError, match=r"false_positive: expected 1 flags, got 2"):
        plot_view(np.zeros((4, 4, 3), np.uint8), [[0, 0, 1, 1]], false_positive=[True, False])
