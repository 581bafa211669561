"""Charts of numbers: box plots of errors per configuration, and curves of a value against a parameter."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InputError
from ._mpl import new_figure

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


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
    first = next(iter(errors_mm.values()))
    panels: dict[str, Mapping[str, ArrayLike]] = (
        dict(errors_mm) if isinstance(first, Mapping) else {"": errors_mm}  # type: ignore[dict-item]
    )
    n = len(panels)
    fig = new_figure(figsize or (max(5.0, 4.5 * n), 4.2))
    axes = fig.subplots(1, n, squeeze=False)[0]
    for ax, (panel, groups) in zip(axes, panels.items()):
        _error_panel(ax, groups, log=log, reference_mm=reference_mm, reference_label=reference_label)
        if xlabel:
            ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if panel:
            ax.set_title(panel)
    if title:
        fig.suptitle(title)
    return fig


def _error_panel(
    ax: Any, groups: Mapping[str, ArrayLike], *, log: bool, reference_mm: float | None, reference_label: str
) -> None:
    """One panel of :func:`plot_error_boxes`: a box per configuration in ``groups`` and a legend of every mark."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

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
    ax.grid(True, axis="y", alpha=0.3)


def _marker_style(line: Any) -> dict[str, Any]:
    """The marker of a drawn Line2D, for a legend handle that looks the same."""
    return {
        "linestyle": line.get_linestyle(),
        "marker": line.get_marker(),
        "markerfacecolor": line.get_markerfacecolor(),
        "markeredgecolor": line.get_markeredgecolor(),
        "color": line.get_color(),
    }


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
    fig = new_figure(figsize)
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
