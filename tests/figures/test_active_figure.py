"""active.png: a title, and a legend that says what the grey dots, the path, the circles and the crosses are."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from mpl_checks import texts_inside_figure  # noqa: E402

from monovisual3d.figures._style import CAMERA_COLOUR, TRUTH_COLOUR  # noqa: E402
from monovisual3d.figures.active import poses_figure  # noqa: E402
from monovisual3d.frames import look_at  # noqa: E402
from monovisual3d.result import DetectedObject  # noqa: E402
from monovisual3d.sim.scenes import paper_scene  # noqa: E402


def test_active_figure_has_a_title_and_a_legend_of_every_mark() -> None:
    from matplotlib.colors import to_rgba

    scene = paper_scene()
    target = scene.centres.mean(axis=0)
    candidates = np.stack([look_at(target + [-0.5, y, 0.1], target) for y in np.linspace(-0.3, 0.3, 7)])
    chosen = [candidates[3], candidates[0], candidates[6]]
    objects = [DetectedObject(c + 0.002, 1.0, radius=0.03) for c in scene.centres]
    fig = poses_figure(scene, candidates, chosen, objects)
    assert fig._suptitle is not None and "3 views chosen among 7 candidates" in fig._suptitle.get_text()
    (legend,) = fig.legends
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[0] == "candidate poses" and labels[1].startswith("chosen poses in order")
    assert labels[2:] == ["true fruit", "final estimates"]
    handles = dict(zip(labels, legend.legend_handles))
    assert to_rgba(handles["true fruit"].get_color()) == to_rgba(TRUTH_COLOUR)
    circles = [p for p in fig.axes[0].patches if to_rgba(p.get_edgecolor()) == to_rgba(TRUTH_COLOUR)]
    assert len(circles) == len(scene.fruits)  # the circles drawn are the legend's "true fruit"
    path = [ln for ln in fig.axes[0].get_lines() if to_rgba(ln.get_color(), 1) == to_rgba(CAMERA_COLOUR, 1)]
    assert len(path) == 1 and len(path[0].get_xdata()) == 3  # the path joins the chosen poses in order
    assert texts_inside_figure(fig) == []
