"""The page: :func:`scene_figure` assembles the traces and the layout, :func:`write_scene_html` writes one
self-contained offline HTML file, :func:`figure_json_from_html` reads the figure back from such a page."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..._extras import require
from ...errors import InputError, InputWarning
from ...result import Result
from ...session import Session
from ...session.load import load_session
from ...truth import ObjectSet, load_objects
from .context import base_axes_traces, workspace_traces
from .fruits import Fruit, load_fruits
from .layout import default_title, scene_layout, scene_scales
from .objects import error_ellipsoid_traces, error_line_traces, fruit_traces, truth_traces
from .views import BoxSelection, cone_traces, select_boxes, view_traces, viewing_cones

if TYPE_CHECKING:  # pragma: no cover
    import plotly.graph_objects as go

#: Height of the figure on the page: the window's, but never more than 3/4 of its width. In a taller box
#: plotly narrows the 3D view's horizontal field and cuts the left of the scene (seen at 1400 x 1800).
PAGE_HEIGHT_CSS = "min(100vh, 75vw)"


def scene_figure(
    session: Session | str | Path | dict[str, Any],
    result: Result | str | Path | dict[str, Any] | None = None,
    truth: ObjectSet | str | Path | dict[str, Any] | None = None,
    *,
    title: str | None = None,
    frustum_depth: float | None = None,
    cone_depth: float | None = None,
) -> go.Figure:
    """The interactive 3D scene of a session, its estimated fruit and the truth.

    Parameters
    ----------
    session : Session, or a session file / dict (:func:`~monovisual3d.session.load.load_session`)
    result : Result, result file or dict, optional, the estimated fruit
    truth : ObjectSet, truth file or dict (``{"objects": [{"position": ..., "radius": ...}]}``), optional
    title : str, optional, default names the session and the counts
    frustum_depth : float, metres, depth of the drawn image planes (default: a quarter of the
        median camera-to-scene distance, 2-30 cm)
    cone_depth : float, metres, depth to which viewing cones are drawn (default: 1.2 x the
        farthest fruit or workspace corner from any camera)

    Past :data:`~monovisual3d.figures.html3d.views.MAX_DRAWN_BOXES` boxes, an evenly spaced subset of the
    boxes is drawn; the page says so in a note and an :class:`~monovisual3d.errors.InputWarning` is issued.
    Detection labels, image names and the session's file name are shown as text, never as markup.

    Returns
    -------
    plotly.graph_objects.Figure

    Examples
    --------
    >>> from monovisual3d.examples import example_session_path, example_truth_path
    >>> fig = scene_figure(example_session_path(), truth=example_truth_path())
    >>> sum(t.meta["kind"] == "frustum" for t in fig.data)
    3
    """
    require("plotly", "viz")
    import plotly.graph_objects as go

    session, fruits, tru = _inputs(session, result, truth, frustum_depth, cone_depth)
    depth, far, axis_len = scene_scales(session, fruits, tru, frustum_depth, cone_depth)
    selection = select_boxes(session)
    traces: list[Any] = base_axes_traces(axis_len) + workspace_traces(session)
    for i, view in enumerate(session.views):
        traces += view_traces(session.camera, i, view, depth, selection.per_view[i])
    cones = viewing_cones(session, far, selection)
    chosen = len(traces) + 1  # the second cone trace: the one the menu restyles
    traces += cone_traces(cones) + fruit_traces(fruits) + error_ellipsoid_traces(fruits)
    if tru is not None and len(tru.positions):
        traces += truth_traces(tru) + (error_line_traces(fruits, tru) if fruits else [])
    note = _thinning_note(session, selection)
    fig = go.Figure(data=traces)
    fig.update_layout(
        **scene_layout(title or default_title(session, fruits if result is not None else None, tru), cones, chosen, note)
    )
    return fig


def _inputs(
    session: Session | str | Path | dict[str, Any],
    result: Result | str | Path | dict[str, Any] | None,
    truth: ObjectSet | str | Path | dict[str, Any] | None,
    frustum_depth: float | None,
    cone_depth: float | None,
) -> tuple[Session, list[Fruit], ObjectSet | None]:
    """The loaded session, estimated fruit and truth of :func:`scene_figure`, with its distances checked."""
    for name, value in (("frustum_depth", frustum_depth), ("cone_depth", cone_depth)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(f"{name}: got {value!r}, expected a positive distance in metres")
    loaded = load_session(session)
    fruits = load_fruits(result) if result is not None else []
    tru = None
    if truth is not None:
        tru = truth if isinstance(truth, ObjectSet) else load_objects(truth)
    return loaded, fruits, tru


def _thinning_note(session: Session, selection: BoxSelection) -> str:
    """The note of a thinned view (empty when every box is drawn), also issued as an :class:`InputWarning`."""
    note = selection.note()
    if note:
        where = f"{session.source}: " if session.source else ""
        warnings.warn(InputWarning(f"{where}view: {note}"), stacklevel=3)
    return note


def write_scene_html(
    session: Session | str | Path | dict[str, Any],
    result: Result | str | Path | dict[str, Any] | None = None,
    truth: ObjectSet | str | Path | dict[str, Any] | None = None,
    *,
    path: str | Path = "scene.html",
    title: str | None = None,
) -> Path:
    """Write :func:`scene_figure` as one self-contained HTML file (plotly.js embedded, works offline).

    Parameters
    ----------
    session, result, truth, title : see :func:`scene_figure`
    path : output file, parent folders are created

    Returns
    -------
    Path, the file written

    Examples
    --------
    >>> import tempfile, os
    >>> from monovisual3d.examples import example_session_path
    >>> p = write_scene_html(example_session_path(), path=os.path.join(tempfile.mkdtemp(), "scene.html"))
    >>> p.stat().st_size > 1_000_000  # plotly.js is inside
    True
    """
    fig = scene_figure(session, result, truth, title=title)
    path = Path(path)
    if path.exists() and path.is_dir():
        raise InputError(f"{path}: is a directory, expected an .html file name")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.write_html(
        path,
        include_plotlyjs=True,
        full_html=True,
        div_id="mv3d-scene",
        default_height=PAGE_HEIGHT_CSS,
        config={"displaylogo": False, "responsive": True, "scrollZoom": True},
    )
    return path


def figure_json_from_html(text: str) -> dict[str, Any]:
    """The figure (``{"data": [...], "layout": {...}}``) embedded in a page written by :func:`write_scene_html`.

    Raises
    ------
    InputError
        When the page holds no ``Plotly.newPlot`` call with a JSON figure.

    Examples
    --------
    >>> figure_json_from_html('Plotly.newPlot("d", [{"type": "scatter3d"}], {"title": "t"}, {})')["data"][0]["type"]
    'scatter3d'
    """
    start = text.rfind("Plotly.newPlot(")
    if start < 0:
        raise InputError("html: no Plotly.newPlot( call found, not a page written by write_scene_html?")
    dec = json.JSONDecoder()
    pos = start + len("Plotly.newPlot(")
    parts = []
    try:
        for _ in range(3):  # div id, data, layout
            while text[pos] in " \t\r\n,":
                pos += 1
            value, pos = dec.raw_decode(text, pos)
            parts.append(value)
    except (json.JSONDecodeError, IndexError) as exc:
        raise InputError(f"html: the Plotly.newPlot( arguments are not JSON: {exc}") from None
    return {"data": parts[1], "layout": parts[2]}
