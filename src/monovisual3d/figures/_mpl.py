"""Matplotlib figures without pyplot: a new Agg-backed figure, saving it, and checked point arrays.

Matplotlib is an optional dependency (extra ``[viz]``); it is imported inside the functions,
so importing :mod:`monovisual3d.figures` works without it and the first figure raises an
ImportError that names the extra. Figures are built as :class:`matplotlib.figure.Figure`
objects directly (no global backend state), so they are safe in scripts, tests and servers.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._extras import require
from ..errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


def new_figure(figsize: tuple[float, float]) -> Figure:
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
    >>> from monovisual3d.figures.charts import plot_error_boxes
    >>> fig = plot_error_boxes({"a": [1.0, 2.0, 3.0]})
    >>> p = save_figure(fig, os.path.join(tempfile.mkdtemp(), "errors.png"))
    >>> p.stat().st_size > 0
    True
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def as_points(a: ArrayLike | None, where: str) -> NDArray[np.float64]:
    """``a`` as points, shape (N, 3) (N = 0 for None or empty); InputError naming ``where`` on NaN or infinity."""
    if a is None:
        return np.zeros((0, 3))
    p = np.asarray(a, dtype=float).reshape(-1, 3) if np.size(a) else np.zeros((0, 3))
    if not np.all(np.isfinite(p)):
        raise InputError(f"{where}: contains NaN or infinity")
    return p
