"""Figures: scenes with true and estimated fruit, error box plots, posterior snapshots.

Matplotlib is an optional dependency (extra ``[viz]``); it is imported inside
the functions, so ``import monovisual3d.viz`` works without it and the first
call raises an ImportError that names the extra. The functions build
:class:`matplotlib.figure.Figure` objects directly (no pyplot, no global
backend state), so they are safe in scripts, tests and servers; save them with
:func:`save_figure`.

All positions are metres in the base frame; the figures show millimetres only
where they print errors.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._extras import require
from .errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from .camera import Camera
    from .grid import VoxelGrid

#: Colours used consistently across figures.
TRUTH_COLOUR = "tab:green"
ESTIMATE_COLOUR = "tab:red"
CAMERA_COLOUR = "tab:blue"
OCCLUDER_COLOUR = "darkolivegreen"
STEM_COLOUR = "saddlebrown"


def _figure(figsize: tuple[float, float]) -> Figure:
    """A new Agg-backed figure without touching pyplot's global state."""
    require("matplotlib", "viz")
    import mpl_toolkits.mplot3d  # noqa: F401  (registers the "3d" projection)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: str | Path, *, dpi: int = 120) -> Path:
    """Write a figure (format from the suffix, e.g. ``.png``) and return the path.

    Examples
    --------
    >>> import tempfile, os
    >>> fig = plot_error_boxes({"a": [1.0, 2.0, 3.0]})
    >>> p = save_figure(fig, os.path.join(tempfile.mkdtemp(), "errors.png"))
    >>> p.stat().st_size > 0
    True
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


# ---------------------------------------------------------------------- 3D helpers
def _sphere_mesh(
    centre: NDArray[np.float64], radius: float, n_u: int = 14, n_v: int = 8
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Wireframe mesh of a sphere, three arrays of shape (n_v, n_u), metres."""
    u = np.linspace(0.0, 2 * np.pi, n_u)
    v = np.linspace(0.0, np.pi, n_v)
    x = centre[0] + radius * np.outer(np.sin(v), np.cos(u))
    y = centre[1] + radius * np.outer(np.sin(v), np.sin(u))
    z = centre[2] + radius * np.outer(np.cos(v), np.ones_like(u))
    return x, y, z


def frustum_lines(camera: Camera, T_base_optical: ArrayLike, depth: float = 0.08) -> NDArray[np.float64]:
    """Edges of a small camera frustum, shape (8, 2, 3), metres, base frame.

    Four edges from the optical centre to the image corners at ``depth`` along
    the optical axis, and the four edges of the image rectangle there.

    Examples
    --------
    >>> from monovisual3d.camera import Camera
    >>> frustum_lines(Camera.from_hfov(640, 480, 69.0), np.eye(4)).shape
    (8, 2, 3)
    """
    T = np.asarray(T_base_optical, dtype=float)
    if T.shape != (4, 4):
        raise InputError(f"T_base_optical: expected shape (4, 4), got {T.shape}")
    corners_uv = np.array([[0.0, 0.0], [camera.width, 0.0], [camera.width, camera.height], [0.0, camera.height]])
    xy = (corners_uv - [camera.cx, camera.cy]) / [camera.fx, camera.fy]
    p_optical = depth * np.column_stack([xy, np.ones(4)])
    p_base = p_optical @ T[:3, :3].T + T[:3, 3]
    origin = T[:3, 3]
    edges = [(origin, p_base[i]) for i in range(4)] + [(p_base[i], p_base[(i + 1) % 4]) for i in range(4)]
    return np.array(edges)


def _set_equal_3d(ax: Any, points: NDArray[np.float64], margin: float = 0.03, zoom: float = 0.8) -> None:
    """Equal scale on the three axes around ``points`` (N, 3).

    ``zoom`` < 1 shrinks the cube inside its axes box so that the tick and axis labels (z on the left,
    x and y at the bottom) stay inside the figure; at 1 the z label is cut off at the figure's left edge.
    """
    lo, hi = points.min(axis=0) - margin, points.max(axis=0) + margin
    centre, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1), zoom=zoom)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))  # fewer ticks: the x and y labels collide at the bottom corner
    ax.tick_params(labelsize=7)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.zaxis.set_rotate_label(False)  # matplotlib's default turns "z (m)" upside down in this view
    ax.set_zlabel("z (m)", rotation=90)


def _draw_spheres(ax: Any, centres: NDArray[np.float64], radii: NDArray[np.float64], **style: Any) -> None:
    for c, r in zip(centres, radii):
        ax.plot_wireframe(*_sphere_mesh(c, float(r)), **style)


def _draw_cameras(ax: Any, camera: Camera, poses: NDArray[np.float64], depth: float, first: int = 0) -> None:
    """Frusta of ``poses`` (N, 4, 4), each numbered on a white tag, from ``first`` (0: the view index of
    ``session.json`` and ``view_NN.png``; 1: "after view 1" of the posterior snapshots)."""
    for i, T in enumerate(poses, start=first):
        for a, b in frustum_lines(camera, T, depth):
            ax.plot(*np.stack([a, b]).T, color=CAMERA_COLOUR, linewidth=1.0)
        ax.text(
            *T[:3, 3],
            f"{i}",
            color=CAMERA_COLOUR,
            fontsize=10,
            fontweight="bold",
            ha="center",
            va="center",
            bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": CAMERA_COLOUR, "alpha": 0.9},
            zorder=10,
        )


def _draw_occluders(ax: Any, occluders: Sequence[Any]) -> None:
    from .sim.scene import Leaf, Stem

    for o in occluders:
        if isinstance(o, Leaf):
            hu, hv = o.half_size
            corners = [
                o.centre + su * hu * o.axis_u + sv * hv * o.axis_v for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))
            ]
            ax.plot(*np.array(corners).T, color=OCCLUDER_COLOUR, linewidth=1.2)
        elif isinstance(o, Stem):
            ax.plot(*np.stack([o.start, o.end]).T, color=STEM_COLOUR, linewidth=1.5)


def _draw_occluder_2d(ax: Any, o: Any, dims: tuple[int, int]) -> None:
    """An occluder projected on the base-frame plane spanned by axes ``dims`` (e.g. (1, 2): y-z)."""
    from .sim.scene import Leaf, Stem

    a, b = dims
    if isinstance(o, Leaf):
        hu, hv = o.half_size
        corners = np.array(
            [o.centre + su * hu * o.axis_u + sv * hv * o.axis_v for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))]
        )
        ax.fill(corners[:, a], corners[:, b], color=OCCLUDER_COLOUR, alpha=0.25, linewidth=0.8)
    elif isinstance(o, Stem):
        ax.plot([o.start[a], o.end[a]], [o.start[b], o.end[b]], color=STEM_COLOUR, linewidth=1.5)


def _as_points(a: ArrayLike | None, where: str) -> NDArray[np.float64]:
    if a is None:
        return np.zeros((0, 3))
    p = np.asarray(a, dtype=float).reshape(-1, 3) if np.size(a) else np.zeros((0, 3))
    if not np.all(np.isfinite(p)):
        raise InputError(f"{where}: contains NaN or infinity")
    return p


# ---------------------------------------------------------------------- public figures
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
    figsize: tuple[float, float] = (15.0, 5.0),
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

    fig = _figure(figsize)
    _scene_3d_panel(fig, tc, tr, ec, er, with_r, camera, P, occluders, frustum_depth)
    _scene_2d_panels(fig, tc, tr, ec, er, with_r, occluders)
    handles = _scene_legend_handles(with_r=bool(with_r), cameras=len(P) > 0, occluders=occluders)
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), fontsize=9, frameon=False)
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
    tc = _as_points(truth_centres, "truth_centres")
    tr = np.asarray(truth_radii, dtype=float).reshape(-1)
    if len(tr) != len(tc):
        raise InputError(f"truth_radii: expected {len(tc)} radii, got {len(tr)}")
    ec = _as_points(estimates, "estimates")
    er = list(estimate_radii) if estimate_radii is not None else [None] * len(ec)
    if len(er) != len(ec):
        raise InputError(f"estimate_radii: expected {len(ec)} entries, got {len(er)}")
    P = np.zeros((0, 4, 4)) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    if len(P) and camera is None:
        raise InputError("camera: needed to draw the poses")
    return tc, tr, ec, er, P


def _scene_3d_panel(
    fig: Figure,
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
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    ax.computed_zorder = False  # draw in zorder, so the camera numbers stay on top of the fruit
    _draw_occluders(ax, occluders)
    _draw_spheres(ax, tc, tr, color=TRUTH_COLOUR, linewidth=0.6)
    if with_r:
        _draw_spheres(
            ax, ec[with_r], np.array([er[i] for i in with_r], dtype=float), color=ESTIMATE_COLOUR, linewidth=0.6, linestyle="--"
        )
    if len(ec):
        ax.scatter(*ec.T, color=ESTIMATE_COLOUR, marker="x", s=30, depthshade=False)
    if camera is not None and len(P):
        _draw_cameras(ax, camera, P, frustum_depth)
    pts = [tc + tr[:, None], tc - tr[:, None], ec] + ([P[:, :3, 3]] if len(P) else [])
    _set_equal_3d(ax, np.concatenate(pts) if any(len(p) for p in pts) else np.zeros((1, 3)))
    ax.view_init(elev=20, azim=-150)
    ax.set_title("3D (cameras numbered by view index)" if len(P) else "3D", fontsize=9)


def _scene_2d_panels(
    fig: Figure,
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
        ax2 = fig.add_subplot(1, 3, 2 + k)
        for o in occluders:
            _draw_occluder_2d(ax2, o, dims)
        for c, r in zip(tc, tr):
            ax2.add_patch(Circle((c[a], c[b]), r, fill=False, color=TRUTH_COLOUR, linewidth=1.2))
        for i in with_r:
            ax2.add_patch(
                Circle((ec[i, a], ec[i, b]), float(er[i]), fill=False, color=ESTIMATE_COLOUR, linestyle="--", linewidth=1.2)
            )
        if len(ec):
            ax2.scatter(ec[:, a], ec[:, b], color=ESTIMATE_COLOUR, marker="x", s=30, zorder=3)
        ax2.set_xlim(hi[a], lo[a])  # base +y on the left, as a camera looking along +x sees it
        ax2.set_ylim(lo[b], hi[b])
        ax2.set_aspect("equal", adjustable="box")
        ax2.set_xlabel("y (m)")
        ax2.set_ylabel("z (m)" if b == 2 else "x (m)")
        ax2.set_title(name, fontsize=9)
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
            label="estimate (centre x, size dashed)" if with_r else "estimate (centre)",
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


def label_positions(boxes_xyxy: ArrayLike, label_sizes: ArrayLike, image_size: tuple[int, int]) -> NDArray[np.float64]:
    """Top-left corners for one label per box, chosen so that labels do not overlap each other.

    Each label is tried at eight places around its box's corners (above the top-left corner
    first, then inside it, above the top-right corner, below the box, beside it); the first
    place that keeps the label inside the image and clear of the labels placed before wins,
    else the place that overlaps least (labels first, then other boxes).

    Parameters
    ----------
    boxes_xyxy : array_like, shape (N, 4), pixels ``(x1, y1, x2, y2)``
    label_sizes : array_like, shape (N, 2), pixels ``(width, height)`` of each label
    image_size : ``(width, height)``, pixels

    Returns
    -------
    xy : ndarray, shape (N, 2), pixels, top-left corner of each label (image y axis points down)

    Examples
    --------
    >>> label_positions([[10, 30, 50, 70], [12, 32, 52, 72]], [[12, 14], [12, 14]], (640, 480)).tolist()
    [[10.0, 16.0], [12.0, 72.0]]
    """
    boxes = np.asarray(boxes_xyxy, dtype=float).reshape(-1, 4)
    sizes = np.asarray(label_sizes, dtype=float).reshape(-1, 2)
    if len(sizes) != len(boxes):
        raise InputError(f"label_sizes: expected {len(boxes)} sizes, got {len(sizes)}")
    W, H = image_size

    def overlap(r: NDArray[np.float64], others: NDArray[np.float64]) -> float:
        if not len(others):
            return 0.0
        dx = np.minimum(r[2], others[:, 2]) - np.maximum(r[0], others[:, 0])
        dy = np.minimum(r[3], others[:, 3]) - np.maximum(r[1], others[:, 1])
        return float(np.sum(np.clip(dx, 0, None) * np.clip(dy, 0, None)))

    placed = np.zeros((0, 4))
    out = np.zeros((len(boxes), 2))
    for n, ((x1, y1, x2, y2), (w, h)) in enumerate(zip(boxes, sizes)):
        candidates = [
            (x1, y1 - h),  # above, left-aligned
            (x1, y1),  # inside the top-left corner
            (x2 - w, y1 - h),  # above, right-aligned
            (x1, y2),  # below, left-aligned
            (x2 - w, y2),  # below, right-aligned
            (x1 - w, y1),  # left of the box
            (x2, y1),  # right of the box
            (x1, y2 - h),  # inside the bottom-left corner
        ]
        others = np.delete(boxes, n, axis=0)
        best, best_cost = None, np.inf
        for x, y in candidates:
            x = float(np.clip(x, 0, max(W - w, 0)))
            y = float(np.clip(y, 0, max(H - h, 0)))
            r = np.array([x, y, x + w, y + h])
            cost = 1000.0 * overlap(r, placed) + overlap(r, others)
            if cost < best_cost - 1e-9:
                best, best_cost = (x, y), cost
            if overlap(r, placed) == 0.0 and cost == 0.0:
                break
        if best_cost > 0:  # fall back on the first place clear of the other labels, ignoring boxes
            for x, y in candidates:
                x = float(np.clip(x, 0, max(W - w, 0)))
                y = float(np.clip(y, 0, max(H - h, 0)))
                if overlap(np.array([x, y, x + w, y + h]), placed) == 0.0:
                    best = (x, y)
                    break
        assert best is not None
        out[n] = best
        placed = np.vstack([placed, [best[0], best[1], best[0] + w, best[1] + h]])
    return out


def plot_view(
    image: ArrayLike,
    boxes_xyxy: ArrayLike,
    *,
    false_positive: ArrayLike | None = None,
    regions: Mapping[str, tuple[int, int, int]] | None = None,
    title: str | None = None,
    image_size: tuple[int, int] | None = None,
    box_colour: str = "#0046ff",
    false_positive_colour: str = "#e600e6",
    figsize: tuple[float, float] = (9.0, 5.4),
) -> Figure:
    """One camera image with its detection boxes, numbered by their index in the view's detections.

    The numbers sit on tags placed by :func:`label_positions`, so no tag hides another.

    Parameters
    ----------
    image : array_like, shape (H, W, 3), uint8 RGB, the picture (pixels map to the axes' pixel coordinates)
    boxes_xyxy : array_like, shape (K, 4), pixels
    false_positive : array_like of bool, shape (K,), optional, boxes drawn in ``false_positive_colour``
    regions : mapping legend text -> RGB colour of the picture's regions (e.g. ``{"fruit": (220, 30, 30)}``)
    title : str, optional
    image_size : ``(width, height)`` in pixels of the camera image the boxes refer to, when the
        picture has another resolution (e.g. a supersampled rendering); default the picture's

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> img = np.full((48, 64, 3), 200, dtype=np.uint8)
    >>> len(plot_view(img, [[10, 10, 30, 30]], title="view 0").axes)
    1
    """
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3:
        raise InputError(f"image: expected shape (H, W, 3), got {img.shape}")
    boxes = np.asarray(boxes_xyxy, dtype=float).reshape(-1, 4)
    fp = np.zeros(len(boxes), bool) if false_positive is None else np.asarray(false_positive, dtype=bool).reshape(-1)
    if len(fp) != len(boxes):
        raise InputError(f"false_positive: expected {len(boxes)} flags, got {len(fp)}")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle

    W, H = image_size if image_size is not None else (img.shape[1], img.shape[0])
    fig = _figure(figsize)
    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(img, extent=(0, W, H, 0), interpolation="nearest")
    # label size in pixels of the image: the axes show W pixels over about 0.8 of the figure's width
    px_per_pt = W / (0.8 * figsize[0] * 72.0)
    fontsize = 9.0
    sizes = np.array([[(0.62 * fontsize * len(str(j)) + 4) * px_per_pt, (fontsize + 5) * px_per_pt] for j in range(len(boxes))])
    xy = label_positions(boxes, sizes, (W, H)) if len(boxes) else np.zeros((0, 2))
    for j, ((x1, y1, x2, y2), f) in enumerate(zip(boxes, fp)):
        colour = false_positive_colour if f else box_colour
        ax.add_patch(Rectangle((x1, y1), x2 - x1, y2 - y1, fill=False, edgecolor=colour, linewidth=1.5))
        lx, ly = xy[j]
        w, h = sizes[j]
        ax.add_patch(Rectangle((lx, ly), w, h, facecolor=colour, edgecolor="none", alpha=0.9))
        ax.text(lx + w / 2, ly + h / 2, str(j), color="white", fontsize=fontsize, fontweight="bold", ha="center", va="center")
    ax.set_xlim(0, W)
    ax.set_ylim(H, 0)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    handles: list[Any] = [
        Patch(facecolor=np.array(c) / 255.0, edgecolor="black", linewidth=0.3, label=name) for name, c in (regions or {}).items()
    ]
    handles.append(Line2D([], [], color=box_colour, linewidth=1.5, label="detection box\n(number = index in\nsession.json)"))
    if fp.any():
        handles.append(Line2D([], [], color=false_positive_colour, linewidth=1.5, label="false positive box"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)
    ax.set_title(title or f"{len(boxes)} detection boxes", fontsize=10)
    return fig


def plot_error_boxes(
    errors_mm: Mapping[str, ArrayLike] | Mapping[str, Mapping[str, ArrayLike]],
    *,
    title: str | None = None,
    ylabel: str = "Euclidean error (mm)",
    xlabel: str = "",
    log: bool = False,
    reference_mm: float | None = None,
    reference_label: str = "",
    figsize: tuple[float, float] | None = None,
) -> Figure:
    """Box plots of errors per configuration, optionally in several panels.

    Parameters
    ----------
    errors_mm : mapping name -> errors (1-D, millimetres), or panel title -> such a mapping
    title : str, optional figure title
    ylabel, xlabel : str, axis labels (no x label when empty)
    log : bool, logarithmic error axis (errors that span decades)
    reference_mm : float, optional, a horizontal reference line (e.g. a claim of the paper)
    reference_label : str, legend text of the reference line

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig = plot_error_boxes({"noise-free": {"square": [1, 2], "gaussian": [3, 4]}}, reference_mm=10)
    >>> len(fig.axes)
    1
    """
    if not errors_mm:
        raise InputError("errors_mm: expected at least one configuration")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    first = next(iter(errors_mm.values()))
    panels: dict[str, Mapping[str, ArrayLike]] = (
        dict(errors_mm) if isinstance(first, Mapping) else {"": errors_mm}  # type: ignore[dict-item]
    )

    n = len(panels)
    fig = _figure(figsize or (max(5.0, 4.5 * n), 4.2))
    axes = fig.subplots(1, n, squeeze=False)[0]
    for ax, (panel, groups) in zip(axes, panels.items()):
        names = list(groups)
        data = [np.asarray(groups[k], dtype=float).reshape(-1) for k in names]
        data = [d[np.isfinite(d)] for d in data]
        parts = ax.boxplot(data, showmeans=True)
        ax.set_xticks(range(1, len(names) + 1), names, rotation=20, ha="right", fontsize=8)
        if log:
            ax.set_yscale("log")
        handles: list[Any] = [Patch(facecolor="none", edgecolor="black", label="quartiles, whiskers 1.5 IQR")]
        for key, label in (("medians", "median"), ("means", "mean"), ("fliers", "outlier")):
            if parts[key]:
                handles.append(Line2D([], [], **_marker_style(parts[key][0]), label=label))
        if reference_mm is not None:
            handles.append(ax.axhline(reference_mm, color="grey", linestyle=":", label=reference_label or "reference"))
        ax.legend(handles=handles, fontsize=7, loc="best")
        if xlabel:
            ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, axis="y", alpha=0.3)
        if panel:
            ax.set_title(panel)
    if title:
        fig.suptitle(title)
    return fig


def _marker_style(line: Any) -> dict[str, Any]:
    """The marker of a drawn Line2D, for a legend handle that looks the same."""
    return {
        "linestyle": line.get_linestyle(),
        "marker": line.get_marker(),
        "markerfacecolor": line.get_markerfacecolor(),
        "markeredgecolor": line.get_markeredgecolor(),
        "color": line.get_color(),
    }


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
        (:attr:`monovisual3d.filter.HistogramFilter.history`)
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
    tc = _as_points(truth_centres, "truth_centres")
    tr = np.zeros(len(tc)) if truth_radii is None else np.asarray(truth_radii, dtype=float).reshape(-1)
    P = np.zeros((0, 4, 4)) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    n = len(snaps)
    fig = _figure(figsize or (4.2 * n + 0.8, 4.4))
    last = None
    keep_all = []
    axes = []
    for i, s in enumerate(snaps):
        ax = fig.add_subplot(1, n, i + 1, projection="3d")
        axes.append(ax)
        pts, scatter, n_above = _posterior_cells(ax, grid, s, threshold, max_points, rng)
        keep_all.append(pts)
        last = scatter if scatter is not None else last
        if len(tc):
            _draw_spheres(ax, tc, tr, color=TRUTH_COLOUR, linewidth=0.5)
        if camera is not None and len(P):
            _draw_cameras(ax, camera, P[: i + 1], 0.06, first=1)
        label = titles[i] if titles is not None and i < len(titles) else f"after view {i + 1}"
        ax.set_title(f"{label}\n{n_above:,} cells >= {threshold:g} max", fontsize=9)
        ax.view_init(elev=20, azim=-150)
    extent = [p for p in keep_all if len(p)] + ([tc] if len(tc) else [])
    if camera is not None and len(P):
        extent.append(P[:, :3, 3])
    ref = np.concatenate(extent) if extent else grid.centres_base(np.array([0, grid.n_cells - 1]))
    for ax in axes:
        _set_equal_3d(ax, ref)
    if last is not None:
        fig.colorbar(last, ax=axes, shrink=0.6, label="p / max(p)")
    _posterior_legend(fig, threshold, truth=len(tc) > 0, cameras=camera is not None and len(P) > 0)
    if suptitle:
        fig.suptitle(suptitle)
    return fig


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


def plot_curves(
    x: ArrayLike,
    curves: Mapping[str, ArrayLike],
    *,
    xlabel: str,
    ylabel: str,
    title: str | None = None,
    log: bool = False,
    figsize: tuple[float, float] = (5.5, 4.0),
) -> Figure:
    """Lines of y against x, one per named curve (e.g. error against the number of fruit).

    Examples
    --------
    >>> len(plot_curves([1, 2], {"a": [1.0, 2.0]}, xlabel="n", ylabel="mm").axes)
    1
    """
    xs = np.asarray(x, dtype=float)
    fig = _figure(figsize)
    ax: Axes = fig.add_subplot(1, 1, 1)
    for name, y in curves.items():
        ys = np.asarray(y, dtype=float)
        if ys.shape != xs.shape:
            raise InputError(f"curves[{name!r}]: expected {xs.shape[0]} values, got {ys.size}")
        ax.plot(xs, ys, marker="o", label=name)
    if log:
        ax.set_yscale("log")
    ax.set_xticks(xs)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    return fig
