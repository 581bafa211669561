"""The posterior grid after each view, as 3D scatters of the cells above a threshold (the paper's Figs. 7-8)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ._draw3d import draw_cameras, draw_spheres, set_equal_3d
from ._mpl import as_points, new_figure
from ._style import CAMERA_COLOUR, TRUTH_COLOUR

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..camera import Camera
    from ..grid import VoxelGrid

#: Depth of the camera frusta drawn in the snapshots, metres.
SNAPSHOT_FRUSTUM_DEPTH_M = 0.06


def _posterior_legend(fig: Figure, threshold: float, *, truth: bool, cameras: bool) -> None:
    """Legend of :func:`plot_posterior_snapshots`: the cells (their colour range), the true fruit and the cameras."""
    from matplotlib import colormaps
    from matplotlib.legend_handler import HandlerTuple
    from matplotlib.lines import Line2D

    # the cells' legend entry shows the colour range they are drawn in (low, middle, high p / max p)
    shades = [threshold, 0.5 * (threshold + 1.0), 1.0]
    cells = tuple(
        Line2D([], [], color=colormaps["viridis"]((v - threshold) / max(1.0 - threshold, 1e-12)), marker="o", linestyle="none")
        for v in shades
    )
    handles: list[Any] = [cells]
    labels = [f"cells with p >= {threshold:g} max(p), coloured by p / max(p)"]
    if truth:
        handles.append(Line2D([], [], color=TRUTH_COLOUR))
        labels.append("true fruit")
    if cameras:
        handles.append(Line2D([], [], color=CAMERA_COLOUR))
        labels.append("camera views (frusta)")
    fig.legend(
        handles,
        labels,
        handler_map={tuple: HandlerTuple(ndivide=None)},
        loc="outside lower center",
        ncol=len(handles),
        fontsize=8,
        frameon=False,
    )


def plot_posterior_snapshots(
    grid: VoxelGrid,
    history: Sequence[ArrayLike],
    *,
    truth_centres: ArrayLike | None = None,
    truth_radii: ArrayLike | None = None,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    threshold: float = 0.1,
    max_points: int = 15_000,
    rng: np.random.Generator | int | None = 0,
    titles: Sequence[str] | None = None,
    suptitle: str | None = None,
    figsize: tuple[float, float] | None = None,
) -> Figure:
    """The posterior grid after each view, as 3D scatters of the cells above a threshold (the paper's Figs. 7-8).

    Parameters
    ----------
    grid : VoxelGrid
    history : sequence of ndarray, each shape (grid.n_cells,) or grid.shape, the posterior after each view
        (:attr:`monovisual3d.methods.paper.filter.HistogramFilter.history`)
    truth_centres, truth_radii : array_like, shapes (M, 3) and (M,), metres, optional true fruit
    camera, poses : optional, the views (poses shape (N, 4, 4)); view ``i`` is drawn in snapshot ``i`` and later
    threshold : float in (0, 1], cells with ``p >= threshold * max(p)`` are drawn, coloured by ``p / max(p)``
    max_points : int, cells drawn per snapshot at most (a random subset above that)
    rng : numpy Generator, seed or None, for the subset
    titles : sequence of str, one per snapshot (default "after view i")

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from monovisual3d.grid import VoxelGrid
    >>> g = VoxelGrid.from_bounds([0, 0, 0], [0.1, 0.1, 0.1], 0.02)
    >>> p = np.random.default_rng(0).random(g.n_cells)
    >>> len(plot_posterior_snapshots(g, [p / p.sum()]).axes)
    2
    """
    snaps = _posterior_snapshots(grid, history, threshold)
    rng = np.random.default_rng(rng)
    tc = as_points(truth_centres, "truth_centres")
    tr = np.zeros(len(tc)) if truth_radii is None else np.asarray(truth_radii, dtype=float).reshape(-1)
    P = np.zeros((0, 4, 4)) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    fig = new_figure(figsize or (4.2 * len(snaps) + 0.8, 4.4))
    axes, keep_all, last = _draw_snapshots(fig, grid, snaps, threshold, max_points, rng, titles)
    for i, ax in enumerate(axes):
        _draw_context(ax, tc, tr, camera, P[: i + 1])
    _share_extent(axes, keep_all, tc, P if camera is not None else np.zeros((0, 4, 4)), grid)
    if last is not None:
        fig.colorbar(last, ax=axes, shrink=0.6, label="p / max(p)")
    _posterior_legend(fig, threshold, truth=len(tc) > 0, cameras=camera is not None and len(P) > 0)
    if suptitle:
        fig.suptitle(suptitle)
    return fig


def _draw_snapshots(
    fig: Figure,
    grid: VoxelGrid,
    snaps: list[NDArray[np.float64]],
    threshold: float,
    max_points: int,
    rng: np.random.Generator,
    titles: Sequence[str] | None,
) -> tuple[list[Any], list[NDArray[np.float64]], Any]:
    """One titled 3D panel per snapshot with its cells; returns the axes, the drawn cells of each and the last scatter."""
    axes, cells, last = [], [], None
    for i, s in enumerate(snaps):
        ax = fig.add_subplot(1, len(snaps), i + 1, projection="3d")
        axes.append(ax)
        pts, scatter, n_above = _posterior_cells(ax, grid, s, threshold, max_points, rng)
        cells.append(pts)
        last = scatter if scatter is not None else last
        label = titles[i] if titles is not None and i < len(titles) else f"after view {i + 1}"
        ax.set_title(f"{label}\n{n_above:,} cells >= {threshold:g} max", fontsize=9)
    return axes, cells, last


def _share_extent(
    axes: list[Any], cells: list[NDArray[np.float64]], tc: NDArray[np.float64], P: NDArray[np.float64], grid: VoxelGrid
) -> None:
    """One equal-scale extent for every snapshot: the drawn cells, the true fruit and the cameras (else the grid)."""
    extent = [p for p in cells if len(p)] + ([tc] if len(tc) else []) + ([P[:, :3, 3]] if len(P) else [])
    ref = np.concatenate(extent) if extent else grid.centres_base(np.array([0, grid.n_cells - 1]))
    for ax in axes:
        set_equal_3d(ax, ref)


def _draw_context(
    ax: Any, tc: NDArray[np.float64], tr: NDArray[np.float64], camera: Camera | None, P: NDArray[np.float64]
) -> None:
    """The true fruit (centres ``tc`` (M, 3), radii ``tr`` (M,)) and the cameras of the views so far ``P`` (K, 4, 4)."""
    if len(tc):
        draw_spheres(ax, tc, tr, color=TRUTH_COLOUR, linewidth=0.5)
    if camera is not None and len(P):
        draw_cameras(ax, camera, P, SNAPSHOT_FRUSTUM_DEPTH_M, first=1)
    ax.view_init(elev=20, azim=-150)


def _posterior_snapshots(grid: VoxelGrid, history: Sequence[ArrayLike], threshold: float) -> list[NDArray[np.float64]]:
    """The checked snapshots of :func:`plot_posterior_snapshots`, each flat, shape (grid.n_cells,)."""
    if not history:
        raise InputError("history: expected at least one posterior snapshot (HistogramFilter(keep_history=True))")
    if not 0.0 < threshold <= 1.0:
        raise InputError(f"threshold: got {threshold}, expected a value in (0, 1]")
    snaps = [np.asarray(h, dtype=float).reshape(-1) for h in history]
    for i, s in enumerate(snaps):
        if s.size != grid.n_cells:
            raise InputError(f"history[{i}]: expected {grid.n_cells} cells, got {s.size}")
    return snaps


def _posterior_cells(
    ax: Any, grid: VoxelGrid, s: NDArray[np.float64], threshold: float, max_points: int, rng: np.random.Generator
) -> tuple[NDArray[np.float64], Any, int]:
    """Scatter the cells of one snapshot ``s`` with ``p >= threshold * max(p)``, coloured by ``p / max(p)``.

    Returns the drawn cells' centres (D, 3) (a random subset of ``max_points`` when more are above the
    threshold), the scatter (None when no cell is drawn) and the number of cells above the threshold.
    """
    m = s.max()
    idx = np.flatnonzero(s >= threshold * m) if m > 0 else np.zeros(0, dtype=np.intp)
    n_above = len(idx)
    if len(idx) > max_points:
        idx = np.sort(rng.choice(idx, max_points, replace=False))
    pts = grid.centres_base(idx) if len(idx) else np.zeros((0, 3))
    scatter = None
    if len(pts):
        scatter = ax.scatter(*pts.T, c=s[idx] / m, cmap="viridis", vmin=threshold, vmax=1.0, s=2, alpha=0.35, depthshade=False)
    return pts, scatter, n_above
