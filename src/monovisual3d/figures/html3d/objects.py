"""Traces of the fruit: the estimates (one colour, numbered as in the ``localize`` table), their
95 % position-error ellipsoids, the truth, and lines from each estimate to its matched truth.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...metrics import match
from ...truth import ObjectSet
from .._style import ERROR_COLOUR, ESTIMATE_COLOUR, TRUTH_COLOUR
from .fruits import Fruit
from .geometry import ellipsoid_mesh, error_ellipsoid_axes, mm, polyline

#: Radius of the marker sphere drawn for an estimate or a true fruit without a size, metres.
POINT_RADIUS_M = 0.005
#: Opacity of the true fruit: see-through, so the estimate inside shows.
TRUTH_OPACITY = 0.25
#: Lighting of the estimates: mostly ambient, so they read as the same red from every side.
ESTIMATE_LIGHTING = {"ambient": 0.7, "diffuse": 0.5, "specular": 0.1}
#: Smallest semi-axis of a drawn error ellipsoid, metres (a degenerate covariance still gives a mesh).
MIN_ERROR_AXIS_M = 1e-5


def fruit_hover(k: int, f: Fruit, axes: NDArray[np.float64]) -> str:
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
        sd = "<br>1-sigma (x, y, z) " + mm(np.sqrt(np.clip(np.diag(f.covariance), 0, None)))
    return f"<b>fruit {k}</b><br>at {mm(f.position)}<br>{size}<br>score {f.score:.3g}{sd}<br>boxes: {seen}<extra></extra>"


def fruit_traces(fruits: list[Fruit]) -> list[Any]:
    """The estimated fruit as meshes of their shapes in :data:`ESTIMATE_COLOUR`, and their numbers beside them.

    Fruit ``k`` is ``result.objects[k]``, row ``k`` of the ``localize`` table; its score is in the hover text.
    """
    traces = []
    tops = []
    for k, f in enumerate(fruits):
        axes = f.semi_axes if f.semi_axes is not None else np.full(3, POINT_RADIUS_M)
        v, fc = ellipsoid_mesh(f.position, axes, f.R_base_fruit)
        tops.append(v[np.argmax(v[:, 2])])
        traces.append(
            mesh3d(
                v,
                fc,
                color=ESTIMATE_COLOUR,
                opacity=1.0,
                flatshading=False,
                lighting=ESTIMATE_LIGHTING,
                name="estimated fruit (numbered as in the table)",
                legendgroup="fruit",
                showlegend=k == 0,
                hovertemplate=fruit_hover(k, f, axes),
                meta={"kind": "fruit", "index": k, "score": f.score},
            )
        )
    if fruits:
        traces.append(fruit_number_trace(np.array(tops)))
    return traces


def fruit_number_trace(tops: NDArray[np.float64]) -> Any:
    """The number ``k`` of each estimated fruit just above the top ``tops[k]`` (K, 3) of its mesh, metres."""
    import plotly.graph_objects as go

    return go.Scatter3d(
        x=tops[:, 0],
        y=tops[:, 1],
        z=tops[:, 2],
        mode="text",
        text=[f"<b>{k}</b>" for k in range(len(tops))],
        textposition="top center",
        textfont={"color": ESTIMATE_COLOUR, "size": 13},
        legendgroup="fruit",
        showlegend=False,
        hoverinfo="skip",
        meta={"kind": "fruit_numbers"},
    )


def error_ellipsoid_traces(fruits: list[Fruit]) -> list[Any]:
    """The 95 % position-error ellipsoid of every fruit with a covariance."""
    traces = []
    for k, f in enumerate(fruits):
        if f.covariance is None:
            continue
        a, R = error_ellipsoid_axes(f.covariance)
        v, fc = ellipsoid_mesh(f.position, np.maximum(a, MIN_ERROR_AXIS_M), R)
        traces.append(
            mesh3d(
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


def mesh3d(vertices: NDArray[np.float64], faces: NDArray[np.int64], **style: Any) -> Any:
    """A plotly ``Mesh3d`` of a triangle mesh (vertices (V, 3), metres, base frame; faces (F, 3) vertex indices)."""
    import plotly.graph_objects as go

    return go.Mesh3d(x=vertices[:, 0], y=vertices[:, 1], z=vertices[:, 2], i=faces[:, 0], j=faces[:, 1], k=faces[:, 2], **style)


def truth_traces(tru: ObjectSet) -> list[Any]:
    """The true fruit as translucent spheres (a 5 mm marker where the radius is unknown)."""
    traces = []
    for t, (c, r) in enumerate(zip(tru.positions, tru.radii)):
        radius = float(r) if np.isfinite(r) else POINT_RADIUS_M
        v, fc = ellipsoid_mesh(c, np.full(3, radius), n_lat=8, n_lon=12)
        size = f"radius {1000 * r:.1f} mm" if np.isfinite(r) else "radius unknown"
        traces.append(
            mesh3d(
                v,
                fc,
                color=TRUTH_COLOUR,
                opacity=TRUTH_OPACITY,
                name="true fruit",
                legendgroup="truth",
                showlegend=t == 0,
                hovertemplate=f"<b>true fruit {t}</b><br>at {mm(c)}<br>{size}<extra></extra>",
                meta={"kind": "truth", "index": t},
            )
        )
    return traces


def error_line_traces(fruits: list[Fruit], tru: ObjectSet) -> list[Any]:
    """One line from each estimate to its matched true fruit (:func:`monovisual3d.metrics.match`)."""
    import plotly.graph_objects as go

    ei, ti = match(np.array([f.position for f in fruits]), tru.positions)
    segs, text = [], []
    for e, t in zip(ei, ti):
        a, b = fruits[e].position, tru.positions[t]
        segs.append(np.stack([a, b]))
        text += [f"fruit {e} -> true fruit {t}: error {1000 * np.linalg.norm(a - b):.1f} mm"] * 3
    xs, ys, zs = polyline(segs)
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
