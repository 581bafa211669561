"""Figure of an active-perception run: candidates, chosen poses in order, fruit (matplotlib, extra ``[viz]``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .._extras import require
from ..result import DetectedObject
from ..sim.scene import Scene

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def poses_figure(
    scene: Scene,
    candidates: NDArray[np.float64],
    chosen: list[NDArray[np.float64]],
    objects: list[DetectedObject] | None = None,
) -> Figure:
    """Top view (x, y) and side view (x, z) of the candidates (grey), the chosen poses (numbered, with
    their viewing direction), the true fruit (circles) and the final estimates (crosses), base frame.

    Returns
    -------
    matplotlib.figure.Figure
    """
    require("matplotlib", "viz")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    fig = Figure(figsize=(10, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    P = np.stack([T[:3, 3] for T in chosen])
    D = np.stack([T[:3, 2] for T in chosen])
    for ax, (i, j), name in zip(axes, ((0, 1), (0, 2)), ("top view", "side view")):
        ax.scatter(candidates[:, i, 3], candidates[:, j, 3], s=8, c="0.7", label="candidates")
        ax.plot(P[:, i], P[:, j], "-", color="C3", alpha=0.4)
        ax.quiver(P[:, i], P[:, j], D[:, i], D[:, j], color="C3", scale=12, width=0.004)
        for k, p in enumerate(P):
            ax.annotate(str(k + 1), (p[i], p[j]), textcoords="offset points", xytext=(4, 4), fontsize=8, color="C3")
        for f in scene.fruits:
            ax.add_patch(Circle((f.centre[i], f.centre[j]), f.radius, fill=False, color="C1"))
        if objects:
            E = np.stack([o.position for o in objects])
            ax.plot(E[:, i], E[:, j], "x", color="k", label="estimates")
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)" if j == 1 else "z (m)")
        ax.set_title(name)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    return fig
