"""``active.png``: an active-perception run seen from the top and the side (matplotlib, extra ``[viz]``).

The candidates (grey dots), the chosen poses in order (the camera's path, numbered, with an arrow
along each optical axis), the true fruit (green circles) and the final estimates (red crosses),
base frame, metres.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..result import DetectedObject
from ..sim.scene import Scene
from ._mpl import new_figure
from ._style import CAMERA_COLOUR, CANDIDATE_COLOUR, ESTIMATE_COLOUR, LEGEND_SIZE, TRUTH_COLOUR

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: Length scale of the optical-axis arrows (matplotlib quiver ``scale``: larger draws shorter arrows).
ARROW_SCALE = 12


def poses_figure(
    scene: Scene,
    candidates: NDArray[np.float64],
    chosen: list[NDArray[np.float64]],
    objects: list[DetectedObject] | None = None,
) -> Figure:
    """Top view (x, y) and side view (x, z) of an active run, with a title and a legend of what is drawn.

    Parameters
    ----------
    scene : Scene, its fruit are drawn as circles of their radius
    candidates : ndarray, shape (C, 4, 4), ``T_base_optical`` of the candidate poses
    chosen : list of ndarray, each shape (4, 4), ``T_base_optical`` of the chosen poses in order
    objects : list of DetectedObject, optional, the final estimates

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure((10.0, 5.0))
    axes = fig.subplots(1, 2)
    P = np.stack([T[:3, 3] for T in chosen])
    D = np.stack([T[:3, 2] for T in chosen])
    E = np.stack([o.position for o in objects]) if objects else np.zeros((0, 3))
    for ax, dims, name in zip(axes, ((0, 1), (0, 2)), ("top view (base x-y)", "side view (base x-z)")):
        _draw_run(ax, dims, scene, candidates, P, D, E)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)" if dims[1] == 1 else "z (m)")
        ax.set_title(name, fontsize=LEGEND_SIZE + 1)
        ax.grid(True, alpha=0.3)
    handles = _legend_handles(estimates=len(E) > 0)
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=LEGEND_SIZE, frameon=False)
    found = f", {len(E)} fruit found" if objects is not None else ""
    fig.suptitle(f"Active perception: {len(chosen)} views chosen among {len(candidates)} candidates{found}")
    return fig


def _draw_run(
    ax: Any,
    dims: tuple[int, int],
    scene: Scene,
    candidates: NDArray[np.float64],
    P: NDArray[np.float64],
    D: NDArray[np.float64],
    E: NDArray[np.float64],
) -> None:
    """One panel: candidates, the path of chosen positions ``P`` (K, 3) with directions ``D`` (K, 3), fruit and estimates ``E``."""
    from matplotlib.patches import Circle

    i, j = dims
    ax.scatter(candidates[:, i, 3], candidates[:, j, 3], s=8, c=CANDIDATE_COLOUR)
    ax.plot(P[:, i], P[:, j], "-", color=CAMERA_COLOUR, alpha=0.5)
    ax.quiver(P[:, i], P[:, j], D[:, i], D[:, j], color=CAMERA_COLOUR, scale=ARROW_SCALE, width=0.004)
    for k, p in enumerate(P):
        ax.annotate(str(k + 1), (p[i], p[j]), textcoords="offset points", xytext=(4, 4), fontsize=8, color=CAMERA_COLOUR)
    for f in scene.fruits:
        ax.add_patch(Circle((f.centre[i], f.centre[j]), f.radius, fill=False, color=TRUTH_COLOUR))
    if len(E):
        ax.plot(E[:, i], E[:, j], "x", color=ESTIMATE_COLOUR)


def _legend_handles(*, estimates: bool) -> list[Any]:
    """Legend entries of :func:`poses_figure`."""
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], color=CANDIDATE_COLOUR, marker="o", linestyle="none", markersize=4, label="candidate poses"),
        Line2D([], [], color=CAMERA_COLOUR, marker=">", label="chosen poses in order (1, 2, ...), arrow = viewing direction"),
        Line2D(
            [], [], color=TRUTH_COLOUR, marker="o", markerfacecolor="none", linestyle="none", markersize=9, label="true fruit"
        ),
    ]
    if estimates:
        handles.append(Line2D([], [], color=ESTIMATE_COLOUR, marker="x", linestyle="none", label="final estimates"))
    return handles
