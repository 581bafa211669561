"""view_NN.png: the picture, its numbered boxes with labels that do not overlap, and the simulated views' pictures."""

from __future__ import annotations

import numpy as np
import pytest

from monovisual3d.errors import InputError
from monovisual3d.figures.views import label_positions, plot_view

pytest.importorskip("matplotlib")
from mpl_checks import texts_inside_figure  # noqa: E402


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


def test_bad_inputs() -> None:
    with pytest.raises(InputError, match=r"label_sizes: expected 2 sizes, got 1"):
        label_positions([[0, 0, 1, 1], [2, 2, 3, 3]], [[1, 1]], (10, 10))
    with pytest.raises(InputError, match=r"image: expected shape \(H, W, 3\), got \(4, 4\)"):
        plot_view(np.zeros((4, 4)), [])
    with pytest.raises(InputError, match=r"false_positive: expected 1 flags, got 2"):
        plot_view(np.zeros((4, 4, 3), np.uint8), [[0, 0, 1, 1]], false_positive=[True, False])


def test_simulated_view_picture_is_a_titled_figure_and_the_simulator_alone_writes_the_bare_picture(tmp_path) -> None:
    from monovisual3d.figures.views import write_view_picture
    from monovisual3d.sim.scenes import paper_scene
    from monovisual3d.sim.simulate import write_simulation

    def size(path) -> tuple[int, int]:
        png = path.read_bytes()
        return int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")

    bare = write_simulation(tmp_path / "bare", paper_scene(), rng=0)
    drawn = write_simulation(tmp_path / "drawn", paper_scene(), rng=0, picture=write_view_picture)
    assert size(bare["view_00"]) == (640, 480)  # the camera's picture
    width, height = size(drawn["view_00"])
    assert width > 640 and height > 480  # a titled figure with a legend around it


def test_the_simulator_does_not_import_the_figures() -> None:
    import subprocess
    import sys

    code = "import sys, monovisual3d.sim.simulate; print(any(m.startswith('monovisual3d.figures') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
