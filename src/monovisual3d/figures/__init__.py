"""Figures of sessions and results (extra ``[viz]``: matplotlib for the PNGs, plotly for the 3D view).

One module per figure kind; each imports its plotting library inside its functions, so
``import monovisual3d.figures`` works without the extra and the first figure raises an
ImportError that names it.

============================  ===================================================================
module                        figure
============================  ===================================================================
:mod:`.scene`                 ``scene.png``: truth, estimates (numbered as in the table), cameras
:mod:`.views`                 ``view_NN.png``: one camera image with its numbered boxes
:mod:`.posterior`             the posterior grid after each view (the paper's Figs. 7-8)
:mod:`.charts`                error box plots, curves of a value against a parameter
:mod:`.active`                ``active.png``: candidates and chosen poses of an active run
:mod:`.html3d`                ``scene.html``: the interactive, offline 3D view (plotly)
:mod:`._style`                colours and text sizes shared by all of them
============================  ===================================================================

The simulator and the methods never import this package; the CLI and the experiments call both.
"""

from __future__ import annotations

from ._mpl import save_figure
from .active import poses_figure
from .charts import plot_curves, plot_error_boxes
from .html3d import scene_figure, write_scene_html
from .posterior import plot_posterior_snapshots
from .scene import plot_scene
from .views import label_positions, plot_view, write_view_picture

__all__ = [
    "label_positions",
    "plot_curves",
    "plot_error_boxes",
    "plot_posterior_snapshots",
    "plot_scene",
    "plot_view",
    "poses_figure",
    "save_figure",
    "scene_figure",
    "write_scene_html",
    "write_view_picture",
]
