"""``scene.png``: true and estimated fruit in 3D with the cameras, in a front view and in a top view.

All positions are metres in the base frame. Estimated fruit carry their number in the result
(``result.objects[k]`` is fruit ``k``, as the ``localize`` table numbers them).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ._draw3d import draw_cameras, draw_occluder_2d, draw_occluders, draw_spheres, set_equal_3d
from ._mpl import as_points, new_figure
from ._style import (
    CAMERA_COLOUR,
    ESTIMATE_COLOUR,
    LEGEND_SIZE,
    NUMBER_SIZE,
    OCCLUDER_COLOUR,
    STEM_COLOUR,
    TITLE_SIZE,
    TRUTH_COLOUR,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..camera import Camera

#: Relative widths of the 3D, front and top panels: the 3D panel, which shows the cameras too, gets the most room.
PANEL_WIDTHS = (1.4, 1.0, 1.0)
#: Where the 3D panel is seen from: from the robot's right, a little behind the cameras, so that no camera
#: (nor its number) stands between the eye and the fruit.
VIEW_ELEVATION_DEG = 18.0
VIEW_AZIMUTH_DEG = -105.0
#: Space around the panels, inches: the legend row under them stays clear of the front view's "y (m)" label.
LEGEND_GAP_IN = 0.15


def plot_scene(
    truth_centres: ArrayLike,
    truth_radii: ArrayLike,
    *,
    estimates: ArrayLike | None = None,
    estimate_radii: Sequence[float | None] | None = None,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    occluders: Sequence[Any] = (),
    title: str | None = None,
    frustum_depth: float = 0.08,
    figsize: tuple[float, float] = (16.0, 6.0),
) -> Figure:
    """True and estimated fruit: in 3D with the cameras, in a front view and in a top view (both zoomed on the fruit).

    The front view is the base y-z plane as a camera looking along base +x sees
    it (base +y on the left); the top view is the base x-y plane (x = depth away
    from that camera), which shows errors in depth.

    Parameters
    ----------
    truth_centres : array_like, shape (M, 3), metres, base frame
    truth_radii : array_like, shape (M,), metres
    estimates : array_like, shape (K, 3), metres, base frame, optional
    estimate_radii : sequence of K floats or None, metres; an estimate with a radius is drawn
        as a red dashed sphere, one without (the paper method) as a red cross only
    camera : Camera, optional, needed to draw ``poses`` as frusta
    poses : array_like, shape (N, 4, 4), ``T_base_optical`` of each view, optional
    occluders : sequence of :class:`~monovisual3d.sim.scene.Leaf` / :class:`~monovisual3d.sim.scene.Stem`
    title : str, optional
    frustum_depth : float, metres, depth of the drawn frusta

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig = plot_scene([[0.6, 0.0, 0.45]], [0.03], estimates=[[0.61, 0.0, 0.45]], estimate_radii=[0.029])
    >>> len(fig.axes)
    3
    """
    tc, tr, ec, er, P = _scene_inputs(truth_centres, truth_radii, estimates, estimate_radii, camera, poses)
    with_r = [i for i, r in enumerate(er) if r is not None and np.isfinite(r)]

    fig = new_figure(figsize)
    grid = fig.add_gridspec(1, 3, width_ratios=PANEL_WIDTHS)
    _scene_3d_panel(fig.add_subplot(grid[0], projection="3d"), tc, tr, ec, er, with_r, camera, P, occluders, frustum_depth)
    _scene_2d_panels([fig.add_subplot(grid[1]), fig.add_subplot(grid[2])], tc, tr, ec, er, with_r, occluders)
    handles = _scene_legend_handles(with_r=bool(with_r), cameras=len(P) > 0, occluders=occluders)
    fig.get_layout_engine().set(h_pad=LEGEND_GAP_IN)  # keeps the legend row clear of the x-axis labels
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=LEGEND_SIZE, frameon=False)
    if title:
        fig.suptitle(title)
    return fig


def _scene_inputs(
    truth_centres: ArrayLike,
    truth_radii: ArrayLike,
    estimates: ArrayLike | None,
    estimate_radii: Sequence[float | None] | None,
    camera: Camera | None,
    poses: ArrayLike | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], list[float | None], NDArray[np.float64]]:
    """The checked inputs of :func:`plot_scene`: truth centres (M, 3) and radii (M,), estimates (K, 3),
    their K radii (None: unknown) and poses (N, 4, 4)."""
    tc = as_points(truth_centres, "truth_centres")
    tr = np.asarray(truth_radii, dtype=float).reshape(-1)
    if len(tr) != len(tc):
        raise InputError(f"truth_radii: expected {len(tc)} radii, got {len(tr)}")
    ec = as_points(estimates, "estimates")
    er = list(estimate_radii) if estimate_radii is not None else [None] * len(ec)
    if len(er) != len(ec):
        raise InputError(f"estimate_radii: expected {len(ec)} entries, got {len(er)}")
    P = np.zeros((0, 4, 4)) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    if len(P) and camera is None:
        raise InputError("camera: needed to draw the poses")
    return tc, tr, ec, er, P


def _scene_3d_panel(
    ax: Any,
    tc: NDArray[np.float64],
    tr: NDArray[np.float64],
    ec: NDArray[np.float64],
    er: list[float | None],
    with_r: list[int],
    camera: Camera | None,
    P: NDArray[np.float64],
    occluders: Sequence[Any],
    frustum_depth: float,
) -> None:
    """The left panel of :func:`plot_scene`: occluders, true and estimated fruit and the cameras in 3D."""
    ax.computed_zorder = False  # draw in zorder, so the camera numbers stay on top of the fruit
    draw_occluders(ax, occluders)
    draw_spheres(ax, tc, tr, color=TRUTH_COLOUR, linewidth=0.6)
    if with_r:
        draw_spheres(
            ax, ec[with_r], np.array([er[i] for i in with_r], dtype=float), color=ESTIMATE_COLOUR, linewidth=0.6, linestyle="--"
        )
    if len(ec):
        ax.scatter(*ec.T, color=ESTIMATE_COLOUR, marker="x", s=30, depthshade=False)
    if camera is not None and len(P):
        draw_cameras(ax, camera, P, frustum_depth)
    pts = [tc + tr[:, None], tc - tr[:, None], ec] + ([P[:, :3, 3]] if len(P) else [])
    set_equal_3d(ax, np.concatenate(pts) if any(len(p) for p in pts) else np.zeros((1, 3)))
    ax.view_init(elev=VIEW_ELEVATION_DEG, azim=VIEW_AZIMUTH_DEG)
    ax.set_title("3D (cameras numbered by view index)" if len(P) else "3D", fontsize=TITLE_SIZE)


def _scene_2d_panels(
    axes: list[Any],
    tc: NDArray[np.float64],
    tr: NDArray[np.float64],
    ec: NDArray[np.float64],
    er: list[float | None],
    with_r: list[int],
    occluders: Sequence[Any],
) -> None:
    """The front (base y-z) and top (base y-x) panels of :func:`plot_scene`, zoomed on the fruit."""
    from matplotlib.patches import Circle

    fruit_pts = np.concatenate([tc + tr[:, None], tc - tr[:, None], ec]) if len(tc) or len(ec) else np.zeros((1, 3))
    lo, hi = fruit_pts.min(axis=0) - 0.02, fruit_pts.max(axis=0) + 0.02
    for k, (dims, name) in enumerate((((1, 2), "front view (base y-z)"), ((1, 0), "top view (base y-x, depth up)"))):
        a, b = dims
        ax2 = axes[k]
        for o in occluders:
            draw_occluder_2d(ax2, o, dims)
        for c, r in zip(tc, tr):
            ax2.add_patch(Circle((c[a], c[b]), r, fill=False, color=TRUTH_COLOUR, linewidth=1.2))
        for i in with_r:
            ax2.add_patch(
                Circle((ec[i, a], ec[i, b]), float(er[i]), fill=False, color=ESTIMATE_COLOUR, linestyle="--", linewidth=1.2)
            )
        if len(ec):
            ax2.scatter(ec[:, a], ec[:, b], color=ESTIMATE_COLOUR, marker="x", s=30, zorder=3)
            for n, p in enumerate(ec):  # the estimate's row in the localize table
                ax2.annotate(
                    f"{n}",
                    (p[a], p[b]),
                    xytext=(3, 3),
                    textcoords="offset points",
                    color=ESTIMATE_COLOUR,
                    fontsize=NUMBER_SIZE - 1,
                )
        ax2.set_xlim(hi[a], lo[a])  # base +y on the left, as a camera looking along +x sees it
        ax2.set_ylim(lo[b], hi[b])
        ax2.set_aspect("equal", adjustable="box")
        ax2.set_xlabel("y (m)")
        ax2.set_ylabel("z (m)" if b == 2 else "x (m)")
        ax2.set_title(name, fontsize=TITLE_SIZE)
        ax2.grid(True, alpha=0.2)


def _scene_legend_handles(*, with_r: bool, cameras: bool, occluders: Sequence[Any]) -> list[Any]:
    """Legend entries of :func:`plot_scene` for what it draws: truth, estimates, and cameras and occluders when present."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [
        Line2D(
            [], [], color=TRUTH_COLOUR, marker="o", markerfacecolor="none", linestyle="none", markersize=10, label="true fruit"
        ),
        Line2D(
            [],
            [],
            color=ESTIMATE_COLOUR,
            marker="x",
            linestyle="--" if with_r else "none",
            label="estimate k (centre x, size dashed; k = table row)" if with_r else "estimate k (centre; k = table row)",
        ),
    ]
    if cameras:
        handles.append(Line2D([], [], color=CAMERA_COLOUR, label="camera frustum (3D panel)"))
    kinds = {type(o).__name__ for o in occluders}
    if "Leaf" in kinds:
        handles.append(Patch(facecolor=OCCLUDER_COLOUR, alpha=0.35, edgecolor=OCCLUDER_COLOUR, label="leaf"))
    if "Stem" in kinds:
        handles.append(Line2D([], [], color=STEM_COLOUR, linewidth=1.5, label="stem"))
    return handles
