"""Interactive 3D view of a session and its fruit: one self-contained, offline HTML file.

The scene is a :class:`plotly.graph_objects.Figure` (extra ``[viz]``), built by pure
functions from a :class:`~monovisual3d.session.Session`, an optional localisation result and
optional ground truth, and written with plotly.js embedded (no CDN, works offline):

- each view's camera as a frustum at its pose, with its detection boxes drawn on the
  frustum's image plane; hovering shows the view index and its detections;
- the viewing cone of every box, hidden until it is picked in the "viewing cone" menu (or
  all at once from the legend);
- the estimated fruit as their shapes (ellipsoid from ``semi_axes`` + ``quaternion_xyzw``,
  else a sphere of ``radius``) coloured by score, with their 95 % position-error ellipsoids
  (from ``covariance``);
- the truth when given, with a line from each estimate to its matched true fruit
  (:func:`monovisual3d.metrics.match`);
- the session's workspace box and the base frame's axes.

Every trace carries ``meta = {"kind": ...}`` (``"frustum"``, ``"boxes"``, ``"cone"``,
``"fruit"``, ``"error_ellipsoid"``, ``"truth"``, ``"error_lines"``, ``"workspace"``,
``"base_axes"``) so programs can find them in the figure's JSON
(:func:`figure_json_from_html`).

All positions are metres in the base frame; hover texts print millimetres.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ._extras import require
from .errors import InputError
from .frames import check_quaternion_xyzw
from .metrics import match
from .result import Result
from .session import Session, _number, _vector, load_session, read_structured_file
from .truth import ObjectSet, load_objects

if TYPE_CHECKING:  # pragma: no cover
    import plotly.graph_objects as go

    from .camera import Camera

#: chi-square quantile of 3 degrees of freedom at 95 %: the 95 % ellipsoid is ``d^T C^-1 d <= CHI2_3DOF_95``.
CHI2_3DOF_95 = 7.814727903251178
#: Radius of the marker sphere drawn for an estimate without a size, metres.
POINT_RADIUS_M = 0.005

CAMERA_COLOUR = "#1f77b4"
BOX_COLOUR = "#ff7f0e"
CONE_COLOUR = "#9467bd"
TRUTH_COLOUR = "#2ca02c"
ERROR_COLOUR = "#d62728"
WORKSPACE_COLOUR = "#7f7f7f"
SCORE_COLORSCALE = "Viridis"


@dataclass(frozen=True)
class Fruit:
    """One estimated fruit as the view draws it.

    Attributes
    ----------
    position : ndarray, shape (3,), float64, metres, base frame
    score : float, the method's score (colour)
    semi_axes : ndarray, shape (3,), metres, the shape's semi-axes (all equal for a sphere), or None when unknown
    R_base_fruit : ndarray, shape (3, 3), rotation of the shape's axes into the base frame
    covariance : ndarray, shape (3, 3), m^2, base frame, or None
    associations : dict view index -> detection index
    """

    position: NDArray[np.float64]
    score: float
    semi_axes: NDArray[np.float64] | None = None
    R_base_fruit: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    covariance: NDArray[np.float64] | None = None
    associations: dict[int, int] = field(default_factory=dict)


# ---------------------------------------------------------------------- inputs
def fruits_from_dict(data: Any) -> list[Fruit]:
    """The estimated fruit of a result (``{"objects": [...]}`` as ``localize --output`` writes it).

    Each object needs ``position``; ``score``, ``radius``, ``semi_axes`` with ``quaternion_xyzw``,
    ``covariance`` and ``associations`` are used when present.

    Raises
    ------
    InputError
        ``objects[i].field: problem``.

    Examples
    --------
    >>> f = fruits_from_dict({"objects": [{"position": [0.5, 0, 0.4], "score": 9.0, "radius": 0.03}]})
    >>> f[0].semi_axes.tolist()
    [0.03, 0.03, 0.03]
    """
    if not isinstance(data, dict) or not isinstance(data.get("objects"), list):
        raise InputError('objects: missing field, expected {"objects": [{"position": [x, y, z]}, ...]}')
    out = []
    for i, o in enumerate(data["objects"]):
        where = f"objects[{i}]"
        if not isinstance(o, dict):
            raise InputError(f"{where}: expected an object, got {type(o).__name__}")
        if "position" not in o:
            raise InputError(f"{where}.position: missing field, expected [x, y, z] in metres")
        position = _vector(o["position"], 3, f"{where}.position")
        score = _number(o.get("score", 0.0), f"{where}.score")
        semi_axes, R = None, np.eye(3)
        if o.get("semi_axes") is not None:
            semi_axes = _vector(o["semi_axes"], 3, f"{where}.semi_axes")
            if q := o.get("quaternion_xyzw"):
                R = _rotation_from_quaternion_xyzw(check_quaternion_xyzw(q, where=f"{where}.quaternion_xyzw"))
        elif o.get("radius") is not None:
            semi_axes = np.full(3, _number(o["radius"], f"{where}.radius"))
        if semi_axes is not None and not np.all(semi_axes > 0):
            name = "semi_axes" if o.get("semi_axes") is not None else "radius"
            raise InputError(f"{where}.{name}: expected positive metres, got {o[name]!r}")
        covariance = None
        if o.get("covariance") is not None:
            try:
                covariance = np.array(o["covariance"], dtype=float)
            except (TypeError, ValueError):
                covariance = None
            if covariance is None or covariance.shape != (3, 3) or not np.all(np.isfinite(covariance)):
                raise InputError(f"{where}.covariance: expected a 3 x 3 matrix of finite numbers (m^2)")
        associations: dict[int, int] = {}
        for k, v in (o.get("associations") or {}).items():
            try:
                associations[int(k)] = int(v)
            except (TypeError, ValueError):
                raise InputError(f"{where}.associations.{k}: expected view index -> detection index, got {v!r}") from None
        out.append(Fruit(position, score, semi_axes, R, covariance, associations))
    return out


def load_fruits(source: Result | dict[str, Any] | str | Path) -> list[Fruit]:
    """:func:`fruits_from_dict` of a :class:`~monovisual3d.result.Result`, a dict or a result file (JSON/YAML)."""
    if isinstance(source, Result):
        return fruits_from_dict(source.to_dict())
    if isinstance(source, dict):
        return fruits_from_dict(source)
    try:
        return fruits_from_dict(read_structured_file(source))
    except InputError as exc:
        raise InputError(f"{source}: {exc}") if not str(exc).startswith(f"{source}:") else exc from None


def _rotation_from_quaternion_xyzw(q: NDArray[np.float64]) -> NDArray[np.float64]:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).as_matrix()


# ---------------------------------------------------------------------- geometry
def image_plane_points(
    camera: Camera, T_base_optical: NDArray[np.float64], uv: NDArray[np.float64], depth: float
) -> NDArray[np.float64]:
    """Points at optical depth ``depth`` along the viewing rays of pixels ``uv``.

    Parameters
    ----------
    camera : Camera
    T_base_optical : ndarray, shape (4, 4)
    uv : ndarray, shape (N, 2), pixels
    depth : float, metres along the optical axis (z of the optical frame)

    Returns
    -------
    p_base : ndarray, shape (N, 3), metres, base frame

    Examples
    --------
    >>> from monovisual3d.camera import Camera
    >>> cam = Camera.from_hfov(640, 480, 90.0)
    >>> image_plane_points(cam, np.eye(4), np.array([[320.0, 240.0]]), 2.0).round(6).tolist()
    [[0.0, 0.0, 2.0]]
    """
    d_optical = camera.rays(np.asarray(uv, dtype=float).reshape(-1, 2))
    p_optical = d_optical * (depth / d_optical[:, 2:3])
    return p_optical @ T_base_optical[:3, :3].T + T_base_optical[:3, 3]


def ellipsoid_mesh(
    centre: NDArray[np.float64],
    semi_axes: NDArray[np.float64],
    R: NDArray[np.float64] | None = None,
    n_lat: int = 10,
    n_lon: int = 16,
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Triangle mesh of the ellipsoid ``centre + R diag(semi_axes) s`` over the unit sphere ``s``.

    Returns
    -------
    vertices : ndarray, shape (V, 3), metres
    faces : ndarray, shape (F, 3), vertex indices

    Examples
    --------
    >>> v, f = ellipsoid_mesh(np.zeros(3), np.array([1.0, 2.0, 3.0]))
    >>> np.abs(v).max(axis=0).round(6).tolist()
    [1.0, 2.0, 3.0]
    """
    lat = np.linspace(0.0, np.pi, n_lat + 1)
    lon = np.linspace(0.0, 2 * np.pi, n_lon, endpoint=False)
    s = np.stack(
        [np.outer(np.sin(lat), np.cos(lon)), np.outer(np.sin(lat), np.sin(lon)), np.outer(np.cos(lat), np.ones_like(lon))],
        axis=-1,
    ).reshape(-1, 3)
    R = np.eye(3) if R is None else R
    vertices = (s * semi_axes) @ R.T + centre
    a = np.arange(n_lat)[:, None] * n_lon
    b = np.arange(n_lon)[None, :]
    i00, i01 = a + b, a + (b + 1) % n_lon
    i10, i11 = i00 + n_lon, i01 + n_lon
    faces = np.concatenate([np.stack([i00, i10, i11], -1).reshape(-1, 3), np.stack([i00, i11, i01], -1).reshape(-1, 3)])
    return vertices, faces


def error_ellipsoid_axes(
    covariance: NDArray[np.float64], chi2: float = CHI2_3DOF_95
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Semi-axes (3,) in metres and axes rotation (3, 3) of ``{d : d^T C^-1 d <= chi2}``.

    Examples
    --------
    >>> a, R = error_ellipsoid_axes(np.diag([1e-4, 4e-4, 9e-4]), chi2=1.0)
    >>> a.round(6).tolist()
    [0.01, 0.02, 0.03]
    """
    C = 0.5 * (covariance + covariance.T)
    w, V = np.linalg.eigh(C)
    if np.linalg.det(V) < 0:
        V[:, 0] = -V[:, 0]
    return np.sqrt(np.clip(w, 0.0, None) * chi2), V


def _polyline(segments: Sequence[NDArray[np.float64]]) -> tuple[list[float | None], list[float | None], list[float | None]]:
    """x, y, z lists of several polylines (each shape (K, 3)) separated by None (plotly's line breaks)."""
    xs: list[float | None] = []
    ys: list[float | None] = []
    zs: list[float | None] = []
    for seg in segments:
        for p in seg:
            xs.append(float(p[0]))
            ys.append(float(p[1]))
            zs.append(float(p[2]))
        xs.append(None)
        ys.append(None)
        zs.append(None)
    return xs, ys, zs


def _mm(p: NDArray[np.float64]) -> str:
    return "(" + ", ".join(f"{1000 * v:.0f}" for v in p) + ") mm"


# ---------------------------------------------------------------------- figure
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
    session : Session, or a session file / dict (:func:`~monovisual3d.session.load_session`)
    result : Result, result file or dict, optional, the estimated fruit
    truth : ObjectSet, truth file or dict (``{"objects": [{"position": ..., "radius": ...}]}``), optional
    title : str, optional, default names the session and the counts
    frustum_depth : float, metres, depth of the drawn image planes (default: a quarter of the
        median camera-to-scene distance, 2-30 cm)
    cone_depth : float, metres, depth to which viewing cones are drawn (default: 1.2 x the
        farthest fruit or workspace corner from any camera)

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

    session = load_session(session)
    fruits = load_fruits(result) if result is not None else []
    tru = None
    if truth is not None:
        tru = truth if isinstance(truth, ObjectSet) else load_objects(truth)
    for name, value in (("frustum_depth", frustum_depth), ("cone_depth", cone_depth)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(f"{name}: got {value!r}, expected a positive distance in metres")

    depth, far, axis_len = _scene_scales(session, fruits, tru, frustum_depth, cone_depth)
    traces: list[Any] = _base_axes_traces(axis_len) + _workspace_traces(session)
    for i, view in enumerate(session.views):
        traces += _view_traces(session.camera, i, view, depth)
    cones = _cone_traces(session, far)
    cone_idx = list(range(len(traces), len(traces) + len(cones)))
    cone_labels = [f"view {t.meta['view']} box #{t.meta['detection']}" for t in cones]
    traces += cones + _fruit_traces(fruits) + _error_ellipsoid_traces(fruits)
    if tru is not None and len(tru.positions):
        traces += _truth_traces(tru) + (_error_line_traces(fruits, tru) if fruits else [])

    fig = go.Figure(data=traces)
    default_title = _default_title(session, fruits if result is not None else None, tru)
    fig.update_layout(**_scene_layout(title or default_title, fruits, cone_idx, cone_labels))
    return fig


def _workspace_corners(session: Session) -> NDArray[np.float64] | None:
    """The 8 corners (8, 3) of the session's workspace box, metres, base frame, or None without a workspace."""
    ws = session.workspace
    if ws is None:
        return None
    return np.array([[x, y, z] for x in (ws.min[0], ws.max[0]) for y in (ws.min[1], ws.max[1]) for z in (ws.min[2], ws.max[2])])


def _scene_scales(
    session: Session, fruits: list[Fruit], tru: ObjectSet | None, frustum_depth: float | None, cone_depth: float | None
) -> tuple[float, float, float]:
    """Depth of the image planes, depth of the viewing cones and length of the base axes, metres.

    The scales follow the cameras' distances to the scene's anchors: the fruit and the truth, else
    the workspace's centre (see :func:`scene_figure` for the defaults).
    """
    centres = np.stack([v.T_base_optical for v in session.views])[:, :3, 3]
    anchors = [f.position for f in fruits] + (list(tru.positions) if tru is not None else [])
    ws = session.workspace
    corners = _workspace_corners(session)
    if not anchors and ws is not None:
        anchors = [0.5 * (ws.min + ws.max)]
    if anchors:
        target = np.mean(anchors, axis=0)
        dist = np.linalg.norm(centres - target, axis=1)
        depth = frustum_depth or float(np.clip(0.25 * np.median(dist), 0.02, 0.3))
        far_pts = np.array(anchors + (list(corners) if corners is not None else []))
        far = cone_depth or 1.2 * float(np.max(np.linalg.norm(centres[:, None] - far_pts[None], axis=-1)))
    else:
        depth = frustum_depth or 0.1
        far = cone_depth or 1.0
    axis_len = float(np.clip(0.2 * np.ptp(np.concatenate([centres, np.array(anchors).reshape(-1, 3)]), axis=0).max(), 0.05, 0.5))
    return depth, far, axis_len


def _base_axes_traces(axis_len: float) -> list[Any]:
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


def _workspace_traces(session: Session) -> list[Any]:
    """The session's workspace box as dashed edges (no trace without a workspace)."""
    import plotly.graph_objects as go

    ws = session.workspace
    corners = _workspace_corners(session)
    if ws is None or corners is None:
        return []
    edges = []
    for a in range(8):
        for b in range(a + 1, 8):
            if np.count_nonzero(corners[a] != corners[b]) == 1:
                edges.append(np.stack([corners[a], corners[b]]))
    return [
        go.Scatter3d(
            **dict(zip("xyz", _polyline(edges), strict=True)),
            mode="lines",
            line={"color": WORKSPACE_COLOUR, "width": 2, "dash": "dash"},
            name="workspace",
            hovertemplate=f"workspace {_mm(ws.min)} to {_mm(ws.max)}<extra></extra>",
            meta={"kind": "workspace"},
        )
    ]


def _box_corners_uv(bbox_xyxy: Sequence[float]) -> NDArray[np.float64]:
    """The closed outline (5, 2) of a box ``x1, y1, x2, y2``, pixels."""
    x1, y1, x2, y2 = bbox_xyxy
    return np.array([[x1, y1], [x2, y1], [x2, y2], [x1, y2], [x1, y1]])


def _view_hover(i: int, view: Any, origin: NDArray[np.float64]) -> str:
    """Hover text of view ``i``'s camera: its image, position and detections."""
    lines = [f"<b>view {i}</b>" + (f" ({view.image})" if view.image else ""), f"camera at {_mm(origin)}"]
    lines.append(f"{len(view.detections)} detection(s):")
    for j, d in enumerate(view.detections):
        score = f", score {d.score:.2f}" if d.score is not None else ""
        lines.append(f"  #{j}: [{', '.join(f'{v:.0f}' for v in d.bbox_xyxy)}] px{score}")
    return "<br>".join(lines)


def _view_traces(cam: Camera, i: int, view: Any, depth: float) -> list[Any]:
    """View ``i``'s frustum to depth ``depth`` metres, its number, and its boxes on the frustum's image plane."""
    import plotly.graph_objects as go

    rect = np.array([[0.0, 0.0], [cam.width, 0.0], [cam.width, cam.height], [0.0, cam.height], [0.0, 0.0]])
    T = view.T_base_optical
    plane = image_plane_points(cam, T, rect, depth)
    origin = T[:3, 3]
    segs = [plane] + [np.stack([origin, plane[c]]) for c in range(4)]
    hover = _view_hover(i, view, origin)
    xs, ys, zs = _polyline(segs)
    traces = [
        go.Scatter3d(
            x=xs,
            y=ys,
            z=zs,
            mode="lines",
            line={"color": CAMERA_COLOUR, "width": 3},
            name=f"view {i}: {len(view.detections)} box" + ("" if len(view.detections) == 1 else "es"),
            legendgroup=f"view{i}",
            hovertext=[hover] * len(xs),
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
            hovertext=[hover],
            hoverinfo="text",
            meta={"kind": "camera_label", "view": i},
        ),
    ]
    if view.detections:
        traces.append(_box_trace(cam, i, view, depth))
    return traces


def _box_trace(cam: Camera, i: int, view: Any, depth: float) -> Any:
    """View ``i``'s detection boxes drawn on its image plane at depth ``depth`` metres."""
    import plotly.graph_objects as go

    T = view.T_base_optical
    box_segs, box_text = [], []
    for j, d in enumerate(view.detections):
        x1, y1, x2, y2 = d.bbox_xyxy
        box_segs.append(image_plane_points(cam, T, _box_corners_uv(d.bbox_xyxy), depth))
        score = f"<br>score {d.score:.2f}" if d.score is not None else ""
        label = f"<br>label {d.label}" if d.label else ""
        box_text += [f"view {i}, detection #{j}<br>[{x1:.0f}, {y1:.0f}, {x2:.0f}, {y2:.0f}] px{score}{label}"] * 6
    xs, ys, zs = _polyline(box_segs)
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


def _cone_traces(session: Session, far: float) -> list[Any]:
    """The viewing cone of every box to depth ``far`` metres, hidden until chosen (``visible="legendonly"``)."""
    import plotly.graph_objects as go

    traces = []
    for i, view in enumerate(session.views):
        T = view.T_base_optical
        origin = T[:3, 3]
        for j, d in enumerate(view.detections):
            far_rect = image_plane_points(session.camera, T, _box_corners_uv(d.bbox_xyxy), far)
            segs = [far_rect] + [np.stack([origin, far_rect[c]]) for c in range(4)]
            xs, ys, zs = _polyline(segs)
            traces.append(
                go.Scatter3d(
                    x=xs,
                    y=ys,
                    z=zs,
                    mode="lines",
                    line={"color": CONE_COLOUR, "width": 2},
                    name="viewing cones of all boxes",
                    legendgroup="cones",
                    showlegend=not traces,
                    visible="legendonly",
                    hovertemplate=f"viewing cone of view {i}, detection #{j}<extra></extra>",
                    meta={"kind": "cone", "view": i, "detection": j},
                )
            )
    return traces


def _fruit_hover(k: int, f: Fruit, axes: NDArray[np.float64]) -> str:
    """Hover text of fruit ``k`` drawn with semi-axes ``axes``: position, size, score, 1-sigma and boxes."""
    if f.semi_axes is None:
        size = "size unknown (drawn as a 5 mm marker)"
    elif np.ptp(axes) < 1e-9:
        size = f"radius {1000 * axes[0]:.1f} mm"
    else:
        size = "semi-axes " + ", ".join(f"{1000 * v:.1f}" for v in axes) + " mm"
    seen = ", ".join(f"view {a} #{b}" for a, b in sorted(f.associations.items())) or "-"
    sd = ""
    if f.covariance is not None:
        sd = "<br>1-sigma (x, y, z) " + _mm(np.sqrt(np.clip(np.diag(f.covariance), 0, None)))
    return f"<b>fruit {k}</b><br>at {_mm(f.position)}<br>{size}<br>score {f.score:.3g}{sd}<br>boxes: {seen}<extra></extra>"


def _fruit_traces(fruits: list[Fruit]) -> list[Any]:
    """The estimated fruit as meshes of their shapes, coloured by score on the figure's coloraxis."""

    traces = []
    for k, f in enumerate(fruits):
        axes = f.semi_axes if f.semi_axes is not None else np.full(3, POINT_RADIUS_M)
        v, fc = ellipsoid_mesh(f.position, axes, f.R_base_fruit)
        traces.append(
            _mesh3d(
                v,
                fc,
                intensity=np.full(len(v), f.score),
                coloraxis="coloraxis",
                opacity=0.9,
                flatshading=False,
                name=f"fruit {k} (score {f.score:.3g})",
                showlegend=True,
                hovertemplate=_fruit_hover(k, f, axes),
                meta={"kind": "fruit", "index": k},
            )
        )
    return traces


def _error_ellipsoid_traces(fruits: list[Fruit]) -> list[Any]:
    """The 95 % position-error ellipsoid of every fruit with a covariance."""

    traces = []
    for k, f in enumerate(fruits):
        if f.covariance is None:
            continue
        a, R = error_ellipsoid_axes(f.covariance)
        v, fc = ellipsoid_mesh(f.position, np.maximum(a, 1e-5), R)
        traces.append(
            _mesh3d(
                v,
                fc,
                color=ERROR_COLOUR,
                opacity=0.18,
                name="95 % position-error ellipsoids",
                legendgroup="error_ellipsoids",
                showlegend=not traces,
                hovertemplate=f"fruit {k}: 95 % position-error ellipsoid<br>semi-axes "
                + ", ".join(f"{1000 * v:.1f}" for v in a)
                + " mm<extra></extra>",
                meta={"kind": "error_ellipsoid", "index": k},
            )
        )
    return traces


def _mesh3d(vertices: NDArray[np.float64], faces: NDArray[np.int64], **style: Any) -> Any:
    """A plotly ``Mesh3d`` of a triangle mesh (vertices (V, 3), metres, base frame; faces (F, 3) vertex indices)."""
    import plotly.graph_objects as go

    return go.Mesh3d(x=vertices[:, 0], y=vertices[:, 1], z=vertices[:, 2], i=faces[:, 0], j=faces[:, 1], k=faces[:, 2], **style)


def _truth_traces(tru: ObjectSet) -> list[Any]:
    """The true fruit as spheres (a 5 mm marker where the radius is unknown)."""

    traces = []
    for t, (c, r) in enumerate(zip(tru.positions, tru.radii)):
        radius = float(r) if np.isfinite(r) else POINT_RADIUS_M
        v, fc = ellipsoid_mesh(c, np.full(3, radius), n_lat=8, n_lon=12)
        size = f"radius {1000 * r:.1f} mm" if np.isfinite(r) else "radius unknown"
        traces.append(
            _mesh3d(
                v,
                fc,
                color=TRUTH_COLOUR,
                opacity=0.3,
                name="true fruit",
                legendgroup="truth",
                showlegend=t == 0,
                hovertemplate=f"<b>true fruit {t}</b><br>at {_mm(c)}<br>{size}<extra></extra>",
                meta={"kind": "truth", "index": t},
            )
        )
    return traces


def _error_line_traces(fruits: list[Fruit], tru: ObjectSet) -> list[Any]:
    """One line from each estimate to its matched true fruit (:func:`monovisual3d.metrics.match`)."""
    import plotly.graph_objects as go

    ei, ti = match(np.array([f.position for f in fruits]), tru.positions)
    segs, text = [], []
    for e, t in zip(ei, ti):
        a, b = fruits[e].position, tru.positions[t]
        segs.append(np.stack([a, b]))
        text += [f"fruit {e} -> true fruit {t}: error {1000 * np.linalg.norm(a - b):.1f} mm"] * 3
    xs, ys, zs = _polyline(segs)
    return [
        go.Scatter3d(
            x=xs,
            y=ys,
            z=zs,
            mode="lines",
            line={"color": ERROR_COLOUR, "width": 5},
            name="error (estimate to matched truth)",
            hovertext=text,
            hoverinfo="text",
            meta={"kind": "error_lines"},
        )
    ]


def _default_title(session: Session, fruits: list[Fruit] | None, tru: ObjectSet | None) -> str:
    """The counts of views, boxes, fruit found (``fruits`` None: no result given) and true fruit, after the session's file name."""
    n_det = sum(len(v.detections) for v in session.views)
    default_title = f"{len(session.views)} views, {n_det} boxes"
    if fruits is not None:
        default_title += f", {len(fruits)} fruit found"
    if tru is not None:
        default_title += f", {len(tru.positions)} true fruit"
    if session.source:
        default_title = f"{Path(session.source).name}: {default_title}"
    return default_title


def _cone_menu(cone_idx: list[int], cone_labels: list[str]) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The "viewing cone" drop-down menu that shows one cone (traces ``cone_idx``) at a time, and its caption."""
    if not cone_idx:
        return [], []
    buttons = [{"label": "no viewing cone", "method": "restyle", "args": [{"visible": ["legendonly"] * len(cone_idx)}, cone_idx]}]
    for n, label in enumerate(cone_labels):
        vis = ["legendonly"] * len(cone_idx)
        vis[n] = True
        buttons.append({"label": label, "method": "restyle", "args": [{"visible": vis}, cone_idx]})
    menu = {"buttons": buttons, "direction": "down", "x": 0.99, "xanchor": "right", "y": 0.99, "yanchor": "top"}
    menu.update({"showactive": True, "active": 0})
    caption = {"text": "viewing cone of one box:", "showarrow": False, "x": 0.8, "xref": "paper", "xanchor": "right"}
    caption.update({"y": 0.985, "yref": "paper", "yanchor": "top"})
    return [menu], [caption]


def _scene_layout(title: str, fruits: list[Fruit], cone_idx: list[int], cone_labels: list[str]) -> dict[str, Any]:
    """The figure's layout: title, 3D axes and view, score colour bar, legend and the viewing-cone menu."""
    scores = np.array([f.score for f in fruits]) if fruits else np.zeros(0)
    updatemenus, annotations = _cone_menu(cone_idx, cone_labels)
    return {
        "title": {"text": title, "x": 0.01},
        "scene": {
            "xaxis": {"title": {"text": "x (m)"}},
            "yaxis": {"title": {"text": "y (m)"}},
            "zaxis": {"title": {"text": "z (m)"}},
            "aspectmode": "data",
            "camera": {"eye": {"x": -1.35, "y": -1.35, "z": 0.9}},  # from behind the robot's left shoulder, all in view
        },
        "coloraxis": {
            "colorscale": SCORE_COLORSCALE,
            "cmin": float(scores.min()) if len(scores) else 0.0,
            "cmax": float(scores.max())
            if len(scores) and np.ptp(scores) > 0
            else (float(scores.max()) + 1.0 if len(scores) else 1.0),
            "colorbar": {"title": {"text": "fruit score"}, "x": 0.0, "xanchor": "left", "len": 0.5},
            "showscale": bool(fruits),
        },
        "legend": {"itemsizing": "constant", "title": {"text": "click to show / hide"}},
        "margin": {"l": 0, "r": 0, "t": 40, "b": 0},
        "updatemenus": updatemenus,
        "annotations": annotations,
    }


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
        default_height="100vh",
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
