"""``view_NN.png``: one camera image with its detection boxes, numbered as in ``session.json``.

:func:`label_positions` places the box numbers so that no number hides another;
:func:`plot_view` draws the picture; :func:`write_view_picture` writes a simulated view's
picture (the titled figure, or the bare picture without matplotlib).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..sim.raycast import OCCLUDER
from ..sim.simulate import BOX_COLOUR as SIM_BOX_RGB
from ..sim.simulate import FALSE_POSITIVE_COLOUR as SIM_FALSE_POSITIVE_RGB
from ..sim.simulate import SimulatedView, view_image, write_png
from ._mpl import new_figure, save_figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: How much more a label's overlap with another label costs than its overlap with another box.
LABEL_OVERLAP_WEIGHT = 1000.0
#: Fraction of the figure's width the picture's axes take (the legend takes the rest): converts points to pixels.
AXES_WIDTH_FRACTION = 0.8


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
    placed = np.zeros((0, 4))
    out = np.zeros((len(boxes), 2))
    for n, (box, (w, h)) in enumerate(zip(boxes, sizes)):
        out[n] = _place_label(_candidate_places(box, w, h), (w, h), image_size, placed, np.delete(boxes, n, axis=0))
        placed = np.vstack([placed, [out[n, 0], out[n, 1], out[n, 0] + w, out[n, 1] + h]])
    return out


def _overlap_area(r: NDArray[np.float64], others: NDArray[np.float64]) -> float:
    """Total area, pixels^2, that rectangle ``r`` (x0, y0, x1, y1) shares with ``others`` (K, 4)."""
    if not len(others):
        return 0.0
    dx = np.minimum(r[2], others[:, 2]) - np.maximum(r[0], others[:, 0])
    dy = np.minimum(r[3], others[:, 3]) - np.maximum(r[1], others[:, 1])
    return float(np.sum(np.clip(dx, 0, None) * np.clip(dy, 0, None)))


def _candidate_places(box: NDArray[np.float64], w: float, h: float) -> list[tuple[float, float]]:
    """The eight top-left corners tried for a ``w`` x ``h`` label of ``box`` (x1, y1, x2, y2), in order of preference."""
    x1, y1, x2, y2 = box
    return [
        (x1, y1 - h),  # above, left-aligned
        (x1, y1),  # inside the top-left corner
        (x2 - w, y1 - h),  # above, right-aligned
        (x1, y2),  # below, left-aligned
        (x2 - w, y2),  # below, right-aligned
        (x1 - w, y1),  # left of the box
        (x2, y1),  # right of the box
        (x1, y2 - h),  # inside the bottom-left corner
    ]


def _place_label(
    candidates: list[tuple[float, float]],
    size: tuple[float, float],
    image_size: tuple[int, int],
    placed: NDArray[np.float64],
    others: NDArray[np.float64],
) -> tuple[float, float]:
    """The first candidate (kept inside the image) clear of the ``placed`` labels and the ``others`` boxes, else the one
    that overlaps least (labels weigh 1000 times boxes), else the first clear of the labels alone."""
    (w, h), (W, H) = size, image_size
    inside = [(float(np.clip(x, 0, max(W - w, 0))), float(np.clip(y, 0, max(H - h, 0)))) for x, y in candidates]
    best, best_cost = inside[0], np.inf
    for x, y in inside:
        r = np.array([x, y, x + w, y + h])
        on_labels = _overlap_area(r, placed)
        cost = LABEL_OVERLAP_WEIGHT * on_labels + _overlap_area(r, others)
        if cost < best_cost - 1e-9:
            best, best_cost = (x, y), cost
        if on_labels == 0.0 and cost == 0.0:
            break
    if best_cost > 0:  # fall back on the first place clear of the other labels, ignoring boxes
        for x, y in inside:
            if _overlap_area(np.array([x, y, x + w, y + h]), placed) == 0.0:
                return (x, y)
    return best


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
    W, H = image_size if image_size is not None else (img.shape[1], img.shape[0])
    fig = new_figure(figsize)
    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(img, extent=(0, W, H, 0), interpolation="nearest")
    colours = [false_positive_colour if f else box_colour for f in fp]
    _draw_numbered_boxes(ax, boxes, colours, (W, H), px_per_pt=W / (AXES_WIDTH_FRACTION * figsize[0] * 72.0))
    ax.set_xlim(0, W)
    ax.set_ylim(H, 0)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    handles = _view_legend_handles(regions or {}, box_colour, false_positive_colour if fp.any() else None)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)
    ax.set_title(title or f"{len(boxes)} detection boxes", fontsize=10)
    return fig


def _draw_numbered_boxes(
    ax: Any, boxes: NDArray[np.float64], colours: list[str], image_size: tuple[int, int], px_per_pt: float
) -> None:
    """Each box (K, 4) in its colour, with its index on a tag of that colour placed by :func:`label_positions`."""
    from matplotlib.patches import Rectangle

    fontsize = 9.0
    sizes = np.array([[(0.62 * fontsize * len(str(j)) + 4) * px_per_pt, (fontsize + 5) * px_per_pt] for j in range(len(boxes))])
    xy = label_positions(boxes, sizes, image_size) if len(boxes) else np.zeros((0, 2))
    for j, ((x1, y1, x2, y2), colour) in enumerate(zip(boxes, colours)):
        ax.add_patch(Rectangle((x1, y1), x2 - x1, y2 - y1, fill=False, edgecolor=colour, linewidth=1.5))
        (lx, ly), (w, h) = xy[j], sizes[j]
        ax.add_patch(Rectangle((lx, ly), w, h, facecolor=colour, edgecolor="none", alpha=0.9))
        ax.text(lx + w / 2, ly + h / 2, str(j), color="white", fontsize=fontsize, fontweight="bold", ha="center", va="center")


def _view_legend_handles(
    regions: Mapping[str, tuple[int, int, int]], box_colour: str, false_positive_colour: str | None
) -> list[Any]:
    """Legend entries of :func:`plot_view`: the picture's regions, the boxes and (when drawn) the false positives."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = [
        Patch(facecolor=np.array(c) / 255.0, edgecolor="black", linewidth=0.3, label=name) for name, c in regions.items()
    ]
    handles.append(Line2D([], [], color=box_colour, linewidth=1.5, label="detection box\n(number = index in\nsession.json)"))
    if false_positive_colour is not None:
        handles.append(Line2D([], [], color=false_positive_colour, linewidth=1.5, label="false positive box"))
    return handles


def write_view_picture(path: str | Path, view: SimulatedView, name: str = "view") -> None:
    """Write the picture of a simulated view: a titled figure with a legend when matplotlib is installed
    (:func:`plot_view`), else the bare :func:`~monovisual3d.sim.simulate.view_image` at the camera's resolution.

    Pass it as ``picture=`` to :func:`monovisual3d.sim.simulate.write_simulation`.
    """
    n_fp = int(np.sum(view.source < 0))
    s = view.rendering.supersample
    labels = view.rendering.labels
    present = {"fruit (one shade each)": (labels >= 0).any(), "leaves and stems": (labels == OCCLUDER).any()}
    colours = {"fruit (one shade each)": (220, 30, 30), "leaves and stems": (40, 140, 40), "background": (200, 200, 200)}
    regions = {k: c for k, c in colours.items() if present.get(k, True)}  # the legend lists what the picture shows
    try:
        fig = plot_view(
            view_image(view, boxes=False),
            view.boxes_xyxy,
            false_positive=view.source < 0,
            image_size=(labels.shape[1] // s, labels.shape[0] // s),
            regions=regions,
            box_colour="#{:02x}{:02x}{:02x}".format(*SIM_BOX_RGB),
            false_positive_colour="#{:02x}{:02x}{:02x}".format(*SIM_FALSE_POSITIVE_RGB),
            title=f"{name}: what the camera saw, {len(view.boxes_xyxy)} detection boxes"
            + (f" ({n_fp} false positive)" if n_fp else ""),
        )
    except ImportError:  # no matplotlib (extra [viz]): the bare picture
        write_png(path, view_image(view))
        return
    save_figure(fig, path, dpi=100)
