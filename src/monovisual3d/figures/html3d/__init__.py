"""Interactive 3D view of a session and its fruit: one self-contained, offline HTML file.

The scene is a :class:`plotly.graph_objects.Figure` (extra ``[viz]``), built by pure
functions from a :class:`~monovisual3d.session.Session`, an optional localisation result and
optional ground truth, and written with plotly.js embedded (no CDN, works offline):

- each view's camera as a frustum at its pose, with its detection boxes drawn on the
  frustum's image plane; hovering shows the view index and its detections;
- the viewing cone of every box, hidden until it is picked in the "viewing cone" menu (or
  all at once from the legend);
- the estimated fruit in red as their shapes (ellipsoid from ``semi_axes`` + ``quaternion_xyzw``,
  else a sphere of ``radius``), numbered as in the ``localize`` table, with their 95 %
  position-error ellipsoids (from ``covariance``); the score is in the hover text;
- the truth when given (translucent green), with a line from each estimate to its matched
  true fruit (:func:`monovisual3d.metrics.match`);
- the session's workspace box and the base frame's axes.

Every trace carries ``meta = {"kind": ...}`` (``"frustum"``, ``"camera_label"``, ``"boxes"``,
``"cones"`` (all), ``"cone"`` (the one chosen in the menu), ``"fruit"``, ``"fruit_numbers"``,
``"error_ellipsoid"``, ``"truth"``, ``"error_lines"``, ``"workspace"``, ``"base_axes"``) so
programs can find them in the figure's JSON (:func:`figure_json_from_html`).

All positions are metres in the base frame; hover texts print millimetres. The cost is linear
in the boxes; past :data:`~monovisual3d.figures.html3d.views.MAX_DRAWN_BOXES` boxes the view
draws an evenly spaced subset and says so. User text (detection labels, image names, the
session's file name) is escaped, so plotly shows it as text.

Modules: :mod:`.fruits` (reading results), :mod:`.geometry`, :mod:`.views` (cameras, boxes,
cones), :mod:`.objects` (fruit, truth, errors), :mod:`.context` (base axes, workspace),
:mod:`.layout` and :mod:`.page` (the figure and the HTML file).
"""

from __future__ import annotations

from .fruits import Fruit, fruits_from_dict, load_fruits
from .geometry import CHI2_3DOF_95, ellipsoid_mesh, error_ellipsoid_axes, image_plane_points
from .page import figure_json_from_html, scene_figure, write_scene_html
from .text import plain_text
from .views import MAX_DRAWN_BOXES, select_boxes

__all__ = [
    "CHI2_3DOF_95",
    "MAX_DRAWN_BOXES",
    "Fruit",
    "ellipsoid_mesh",
    "error_ellipsoid_axes",
    "figure_json_from_html",
    "fruits_from_dict",
    "image_plane_points",
    "load_fruits",
    "plain_text",
    "scene_figure",
    "select_boxes",
    "write_scene_html",
]
