"""The figure around the traces: scales, title, the viewing-cone menu, axes, legend and margins."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .context import workspace_corners
from .fruits import Fruit
from .text import plain_text
from .views import Cone

if TYPE_CHECKING:  # pragma: no cover
    from ...session import Session
    from ...truth import ObjectSet

#: Depth of the image planes as a fraction of the median camera-to-scene distance, and its bounds, metres.
FRUSTUM_DEPTH_FRACTION = 0.25
FRUSTUM_DEPTH_RANGE_M = (0.02, 0.3)
#: Viewing cones reach this factor times the farthest anchor (fruit, truth, workspace corner) from a camera.
CONE_REACH = 1.2
#: Base axes: this fraction of the scene's extent, within bounds, metres.
AXIS_FRACTION = 0.2
AXIS_RANGE_M = (0.05, 0.5)
#: Where the eye looks from (plotly's units of the scene box): behind the robot's left shoulder. Far enough
#: that the whole box, its tick labels and axis titles stay inside tall and wide windows alike.
EYE = {"x": -1.75, "y": -1.75, "z": 1.15}
#: Margins around the 3D scene, pixels: room for the title on top and the axis titles at the sides.
MARGIN = {"l": 10, "r": 10, "t": 50, "b": 10}


def scene_scales(
    session: Session, fruits: list[Fruit], tru: ObjectSet | None, frustum_depth: float | None, cone_depth: float | None
) -> tuple[float, float, float]:
    """Depth of the image planes, depth of the viewing cones and length of the base axes, metres.

    The scales follow the cameras' distances to the scene's anchors: the fruit and the truth, else
    the workspace's centre (see :func:`~monovisual3d.figures.html3d.scene_figure` for the defaults).
    """
    centres = np.stack([v.T_base_optical for v in session.views])[:, :3, 3]
    anchors = [f.position for f in fruits] + (list(tru.positions) if tru is not None else [])
    ws = session.workspace
    corners = workspace_corners(session)
    if not anchors and ws is not None:
        anchors = [0.5 * (ws.min + ws.max)]
    if anchors:
        target = np.mean(anchors, axis=0)
        dist = np.linalg.norm(centres - target, axis=1)
        depth = frustum_depth or float(np.clip(FRUSTUM_DEPTH_FRACTION * np.median(dist), *FRUSTUM_DEPTH_RANGE_M))
        far_pts = np.array(anchors + (list(corners) if corners is not None else []))
        far = cone_depth or CONE_REACH * float(np.max(np.linalg.norm(centres[:, None] - far_pts[None], axis=-1)))
    else:
        depth = frustum_depth or 0.1
        far = cone_depth or 1.0
    extent = np.ptp(np.concatenate([centres, np.array(anchors).reshape(-1, 3)]), axis=0).max()
    axis_len = float(np.clip(AXIS_FRACTION * extent, *AXIS_RANGE_M))
    return depth, far, axis_len


def default_title(session: Session, fruits: list[Fruit] | None, tru: ObjectSet | None) -> str:
    """The counts of views, boxes, fruit found (``fruits`` None: no result given) and true fruit, after the
    session's file name (shown as text)."""
    n_det = sum(len(v.detections) for v in session.views)
    n_views = len(session.views)
    title = f"{n_views} view{'' if n_views == 1 else 's'}, {n_det:,} box{'' if n_det == 1 else 'es'}"
    if fruits is not None:
        title += f", {len(fruits)} fruit found"
    if tru is not None:
        title += f", {len(tru.positions)} true fruit"
    if session.source:
        title = f"{plain_text(Path(session.source).name)}: {title}"
    return title


def cone_menu(cones: list[Cone], chosen: int) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The "viewing cone" drop-down menu and its caption.

    Each entry restyles the one trace ``chosen`` (its index in the figure's data) with the coordinates of
    its cone, so the menu's size grows linearly with the cones (no per-pair visibility lists).
    """
    if not cones:
        return [], []
    buttons = [{"label": "no viewing cone", "method": "restyle", "args": [{"x": [[]], "y": [[]], "z": [[]]}, [chosen]]}]
    for c in cones:
        buttons.append(
            {
                "label": f"view {c.view} box #{c.detection}",
                "method": "restyle",
                "args": [{"x": [c.x], "y": [c.y], "z": [c.z]}, [chosen]],
            }
        )
    # bottom right, opening upwards: clear of the legend above it, however many views it lists
    menu = {"buttons": buttons, "direction": "up", "x": 0.99, "xanchor": "right", "y": 0.02, "yanchor": "bottom"}
    menu.update({"showactive": True, "active": 0})
    caption = {"text": "viewing cone of one box:", "showarrow": False, "x": 0.99, "xref": "paper", "xanchor": "right"}
    caption.update({"y": 0.075, "yref": "paper", "yanchor": "bottom"})
    return [menu], [caption]


def note_annotation(text: str) -> dict[str, Any]:
    """A line of small grey text at the bottom left of the page (e.g. that the boxes were thinned)."""
    return {
        "text": text,
        "showarrow": False,
        "x": 0.01,
        "xref": "paper",
        "xanchor": "left",
        "y": 0.01,
        "yref": "paper",
        "yanchor": "bottom",
        "font": {"size": 12, "color": "#555555"},
    }


def scene_layout(title: str, cones: list[Cone], chosen: int, note: str = "") -> dict[str, Any]:
    """The figure's layout: title, 3D axes and view, legend, the viewing-cone menu and a note (when not empty)."""
    updatemenus, annotations = cone_menu(cones, chosen)
    if note:
        annotations.append(note_annotation(note))
    return {
        "title": {"text": title, "x": 0.01},
        "scene": {
            "xaxis": {"title": {"text": "x (m)"}},
            "yaxis": {"title": {"text": "y (m)"}},
            "zaxis": {"title": {"text": "z (m)"}},
            "aspectmode": "data",
            "camera": {"eye": EYE},
            "domain": {"x": [0.0, 0.8], "y": [0.0, 1.0]},
        },
        "legend": {"itemsizing": "constant", "title": {"text": "click to show / hide"}, "x": 0.81, "xanchor": "left"},
        "margin": MARGIN,
        "updatemenus": updatemenus,
        "annotations": annotations,
    }
