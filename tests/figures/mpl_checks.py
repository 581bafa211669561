"""Checks shared by the matplotlib figure tests: texts that leave the figure, texts that overlap."""

from __future__ import annotations

from typing import Any


def texts_inside_figure(fig: Any) -> list[str]:
    """Texts (titles, axis labels, legend entries) whose drawn extent leaves the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    out = []
    texts = list(fig.texts) + ([fig._suptitle] if fig._suptitle is not None else [])
    for ax in fig.axes:
        texts += [ax.title, ax.xaxis.label, ax.yaxis.label] + ([ax.zaxis.label] if hasattr(ax, "zaxis") else [])
        if ax.get_legend() is not None:
            texts += list(ax.get_legend().get_texts())
    for leg in fig.legends:
        texts += list(leg.get_texts())
    for t in texts:
        if not t.get_text() or not t.get_visible():
            continue
        e = t.get_window_extent(renderer)
        if e.x0 < box.x0 - 1 or e.y0 < box.y0 - 1 or e.x1 > box.x1 + 1 or e.y1 > box.y1 + 1:
            out.append(t.get_text())
    return out


def overlapping(a: Any, b: Any, fig: Any) -> bool:
    """Whether two drawn artists' window extents overlap (pixels)."""
    renderer = fig.canvas.get_renderer()
    ea, eb = a.get_window_extent(renderer), b.get_window_extent(renderer)
    return bool(ea.x0 < eb.x1 and eb.x0 < ea.x1 and ea.y0 < eb.y1 and eb.y0 < ea.y1)
