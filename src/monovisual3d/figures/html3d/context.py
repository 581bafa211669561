"""Traces that place the scene: the base frame's axes and the session's workspace box."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .._style import WORKSPACE_COLOUR
from .geometry import mm, polyline

if TYPE_CHECKING:  # pragma: no cover
    from ...session import Session


def workspace_corners(session: Session) -> NDArray[np.float64] | None:
    """The 8 corners (8, 3) of the session's workspace box, metres, base frame, or None without a workspace."""
    ws = session.workspace
    if ws is None:
        return None
    return np.array([[x, y, z] for x in (ws.min[0], ws.max[0]) for y in (ws.min[1], ws.max[1]) for z in (ws.min[2], ws.max[2])])


def base_axes_traces(axis_len: float) -> list[Any]:
    """The base frame's x, y and z axes (red, green, blue) of length ``axis_len`` metres."""
    import plotly.graph_objects as go

    traces = []
    for k, (name, colour) in enumerate((("x", "red"), ("y", "green"), ("z", "blue"))):
        end = np.zeros(3)
        end[k] = axis_len
        traces.append(
            go.Scatter3d(
                x=[0.0, end[0]],
                y=[0.0, end[1]],
                z=[0.0, end[2]],
                mode="lines+text",
                text=["", name],
                textposition="top center",
                line={"color": colour, "width": 6},
                name="base frame (x red, y green, z blue)",
                legendgroup="base",
                showlegend=k == 0,
                hovertemplate=f"base frame {name} axis ({1000 * axis_len:.0f} mm)<extra></extra>",
                meta={"kind": "base_axes", "axis": name},
            )
        )
    return traces


def workspace_traces(session: Session) -> list[Any]:
    """The session's workspace box as dashed edges (no trace without a workspace)."""
    import plotly.graph_objects as go

    ws = session.workspace
    corners = workspace_corners(session)
    if ws is None or corners is None:
        return []
    edges = []
    for a in range(8):
        for b in range(a + 1, 8):
            if np.count_nonzero(corners[a] != corners[b]) == 1:
                edges.append(np.stack([corners[a], corners[b]]))
    return [
        go.Scatter3d(
            **dict(zip("xyz", polyline(edges), strict=True)),
            mode="lines",
            line={"color": WORKSPACE_COLOUR, "width": 2, "dash": "dash"},
            name="workspace",
            hovertemplate=f"workspace {mm(ws.min)} to {mm(ws.max)}<extra></extra>",
            meta={"kind": "workspace"},
        )
    ]
