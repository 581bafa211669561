"""Traces of the cameras: frusta with their numbers, detection boxes on the image planes, viewing cones.

Past :data:`MAX_DRAWN_BOXES` boxes in a session the view draws an evenly spaced subset of them
(:func:`select_boxes`), so that the page stays a few megabytes and opens in a browser; the page
and the console say so. Every structure here grows linearly with the boxes drawn: the cone menu
holds one cone per entry and restyles a single "chosen cone" trace.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .._style import BOX_COLOUR, CAMERA_COLOUR, CONE_COLOUR
from .geometry import image_plane_points, mm, polyline
from .text import plain_text

if TYPE_CHECKING:  # pragma: no cover
    from ...camera import Camera
    from ...session import Session, View

#: Boxes the view draws at most (outlines, viewing cones and cone-menu entries), over all views. Past it, an
#: evenly spaced subset by index over the views in order: about 10 MB of page, which a browser opens in seconds.
MAX_DRAWN_BOXES = 2000
#: Detections listed in a camera's hover text at most; the rest are counted.
MAX_HOVER_DETECTIONS = 20


@dataclass(frozen=True)
class BoxSelection:
    """Which boxes the view draws.

    Attributes
    ----------
    per_view : tuple of ndarray, one per view, int64, the indices of the drawn detections of that view
    total : int, boxes in the session
    """

    per_view: tuple[NDArray[np.int64], ...]
    total: int

    @property
    def drawn(self) -> int:
        """Boxes drawn."""
        return int(sum(len(d) for d in self.per_view))

    @property
    def thinned(self) -> bool:
        """Whether some boxes are left out."""
        return self.drawn < self.total

    def note(self) -> str:
        """One line saying how the boxes were thinned (empty when all are drawn)."""
        if not self.thinned:
            return ""
        return (
            f"drew {self.drawn:,} of {self.total:,} boxes (evenly spaced over the views; "
            f"at most {MAX_DRAWN_BOXES:,} boxes, cones and menu entries are drawn)"
        )


def select_boxes(session: Session, max_boxes: int = MAX_DRAWN_BOXES) -> BoxSelection:
    """All boxes, or ``max_boxes`` of them evenly spaced by index over the views in order (deterministic).

    Examples
    --------
    >>> from monovisual3d.examples import example_session_path
    >>> from monovisual3d import load_session
    >>> sel = select_boxes(load_session(example_session_path()), max_boxes=2)
    >>> sel.drawn, sel.thinned
    (2, True)
    """
    counts = np.array([len(v.detections) for v in session.views], dtype=np.int64)
    total = int(counts.sum())
    starts = np.concatenate([[0], np.cumsum(counts)])
    if total <= max_boxes:
        keep = np.arange(total, dtype=np.int64)
    else:
        keep = np.unique(np.linspace(0, total - 1, max_boxes).round().astype(np.int64))
    per_view = tuple(keep[(keep >= starts[i]) & (keep < starts[i + 1])] - starts[i] for i in range(len(counts)))
    return BoxSelection(per_view, total)


def box_corners_uv(bbox_xyxy: Sequence[float]) -> NDArray[np.float64]:
    """The closed outline (5, 2) of a box ``x1, y1, x2, y2``, pixels."""
    x1, y1, x2, y2 = bbox_xyxy
    return np.array([[x1, y1], [x2, y1], [x2, y2], [x1, y2], [x1, y1]])


def view_hover(i: int, view: View, origin: NDArray[np.float64]) -> str:
    """Hover text of view ``i``'s camera: its image (as text), position and first detections."""
    image = f" ({plain_text(view.image)})" if view.image else ""
    lines = [f"<b>view {i}</b>{image}", f"camera at {mm(origin)}", f"{len(view.detections)} detection(s):"]
    for j, d in enumerate(view.detections[:MAX_HOVER_DETECTIONS]):
        score = f", score {d.score:.2f}" if d.score is not None else ""
        lines.append(f"  #{j}: [{', '.join(f'{v:.0f}' for v in d.bbox_xyxy)}] px{score}")
    if len(view.detections) > MAX_HOVER_DETECTIONS:
        lines.append(f"  ... and {len(view.detections) - MAX_HOVER_DETECTIONS} more")
    return "<br>".join(lines)


def view_traces(cam: Camera, i: int, view: View, depth: float, drawn: NDArray[np.int64]) -> list[Any]:
    """View ``i``'s frustum to depth ``depth`` metres, its number, and its ``drawn`` boxes on the image plane."""
    import plotly.graph_objects as go

    rect = np.array([[0.0, 0.0], [cam.width, 0.0], [cam.width, cam.height], [0.0, cam.height], [0.0, 0.0]])
    T = view.T_base_optical
    plane = image_plane_points(cam, T, rect, depth)
    origin = T[:3, 3]
    xs, ys, zs = polyline([plane] + [np.stack([origin, plane[c]]) for c in range(4)])
    hover = view_hover(i, view, origin)
    n = len(view.detections)
    traces = [
        go.Scatter3d(
            x=xs,
            y=ys,
            z=zs,
            mode="lines",
            line={"color": CAMERA_COLOUR, "width": 3},
            name=f"view {i}: {n} box" + ("" if n == 1 else "es"),
            legendgroup=f"view{i}",
            hovertext=hover,
            hoverinfo="text",
            meta={"kind": "frustum", "view": i},
        ),
        go.Scatter3d(
            x=[float(origin[0])],
            y=[float(origin[1])],
            z=[float(origin[2])],
            mode="text",
            text=[f"<b>{i}</b>"],
            textfont={"color": CAMERA_COLOUR, "size": 14},
            legendgroup=f"view{i}",
            showlegend=False,
            hovertext=hover,
            hoverinfo="text",
            meta={"kind": "camera_label", "view": i},
        ),
    ]
    if len(drawn):
        traces.append(box_trace(cam, i, view, depth, drawn))
    return traces


def box_trace(cam: Camera, i: int, view: View, depth: float, drawn: NDArray[np.int64]) -> Any:
    """View ``i``'s detection boxes ``drawn`` on its image plane at depth ``depth`` metres; labels shown as text."""
    import plotly.graph_objects as go

    T = view.T_base_optical
    box_segs, box_text = [], []
    for j in drawn.tolist():
        d = view.detections[j]
        x1, y1, x2, y2 = d.bbox_xyxy
        box_segs.append(image_plane_points(cam, T, box_corners_uv(d.bbox_xyxy), depth))
        score = f"<br>score {d.score:.2f}" if d.score is not None else ""
        label = f"<br>label {plain_text(d.label)}" if d.label else ""
        box_text += [f"view {i}, detection #{j}<br>[{x1:.0f}, {y1:.0f}, {x2:.0f}, {y2:.0f}] px{score}{label}"] * 6
    xs, ys, zs = polyline(box_segs)
    return go.Scatter3d(
        x=xs,
        y=ys,
        z=zs,
        mode="lines",
        line={"color": BOX_COLOUR, "width": 4},
        name=f"view {i} boxes",
        legendgroup=f"view{i}",
        showlegend=False,
        hovertext=box_text,
        hoverinfo="text",
        meta={"kind": "boxes", "view": i},
    )


@dataclass(frozen=True)
class Cone:
    """The viewing cone of box ``detection`` of view ``view``: its far rectangle and the 4 edges from the camera.

    ``x``, ``y``, ``z`` are plotly polyline lists (None between the 5 lines), metres, base frame.
    """

    view: int
    detection: int
    x: list[float | None]
    y: list[float | None]
    z: list[float | None]


def viewing_cones(session: Session, far: float, selection: BoxSelection) -> list[Cone]:
    """The viewing cone of every drawn box, to optical depth ``far`` metres."""
    cones = []
    for i, view in enumerate(session.views):
        T = view.T_base_optical
        origin = T[:3, 3]
        for j in selection.per_view[i].tolist():
            far_rect = image_plane_points(session.camera, T, box_corners_uv(view.detections[j].bbox_xyxy), far)
            xs, ys, zs = polyline([far_rect] + [np.stack([origin, far_rect[c]]) for c in range(4)])
            cones.append(Cone(i, j, xs, ys, zs))
    return cones


def cone_traces(cones: list[Cone]) -> list[Any]:
    """Two traces: all cones at once (hidden until picked in the legend), and the one chosen in the menu (empty at first)."""
    import plotly.graph_objects as go

    if not cones:
        return []
    xs, ys, zs, text = [], [], [], []
    for c in cones:
        xs += c.x
        ys += c.y
        zs += c.z
        text += [f"viewing cone of view {c.view}, detection #{c.detection}"] * len(c.x)
    style = {"mode": "lines", "line": {"color": CONE_COLOUR, "width": 2}, "hoverinfo": "text"}
    every = go.Scatter3d(
        x=xs,
        y=ys,
        z=zs,
        hovertext=text,
        name=f"viewing cones of all {len(cones)} boxes drawn",
        visible="legendonly",
        meta={"kind": "cones", "count": len(cones)},
        **style,
    )
    chosen = go.Scatter3d(
        x=[],
        y=[],
        z=[],
        name="viewing cone chosen in the menu",
        showlegend=False,
        hovertext="the viewing cone chosen in the menu",
        meta={"kind": "cone"},
        **style,
    )
    return [every, chosen]
