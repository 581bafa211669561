"""Views whose boxes all sit off the same way: a sign that the view's reported pose is off.

After the estimate, each object seen in :data:`MIN_VIEWS` or more views predicts its box in every view it was seen in
(its fitted model: :func:`.aspects.solid_boxes`). Where a view's pose is right, the offsets of the observed box centres
from those predictions are noise, independent from object to object. Where the pose is off by a rotation ``theta``,
every object's box is off by about ``f theta`` pixels, the same way (the fit takes up only part of it: each object
also answers to its other views).

Per view, each offset is divided by its centre's noise (the sensor model's edge noise over ``sqrt(2)``,
:func:`.sensor.box_edge_sigma_px`) and clipped at :data:`CLIP_SIGMAS`, so that a box a leaf cuts counts as one outlier,
not as a shift; the mean of the M offsets so scaled is ``N(0, I / M)`` under noise, so ``M |mean|^2`` is chi-square
with 2 degrees of freedom. A view is reported when that exceeds :data:`CHI2_THRESHOLD` and the mean offset is at least
:data:`MIN_SHIFT_PX`. Boxes on the image border (:func:`.sensor.censored_edges`) are left out: their centre is not the
object's.

Only a warning: the estimate is not changed (state the pose error, ``pose_sigma_mm`` / ``pose_sigma_deg``, to have
each view's pose corrected jointly with the objects, :mod:`.bundle`). It detects errors of about a degree and more
with a few objects in view; a few tenths of a degree stay within the boxes' noise.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...geometry.ellipsoid import Ellipsoid
from ...verdict import Cause
from .aspects import object_boxes, solid_boxes
from .problem import Problem
from .sensor import box_edge_sigma_px, censored_edges
from .state import Found, State

#: Views an object must be seen in for its predicted boxes to judge a view (with two, the fit splits any offset
#: evenly between them and both views look shifted).
MIN_VIEWS = 3
#: Objects a view needs for a common shift to mean something.
MIN_OBJECTS = 2
#: A scaled offset beyond this many sigmas per axis counts as this many (a cut box, an association error).
CLIP_SIGMAS = 3.0
#: Chi-square (2 degrees of freedom) a view's mean scaled offset must exceed: a false alarm rate of exp(-25 / 2) =
#: 4e-6 per view under the sensor model's noise. Simulated box noise is larger than the model's centre noise (the
#: paper's 5 % moves a centre by 5 % of the size, the model's edges by 5 % plus 1 px over sqrt(2)), hence the margin.
CHI2_THRESHOLD = 25.0
#: Smallest mean offset reported, pixels: less is below any detector's precision.
MIN_SHIFT_PX = 2.0


def shift_message(shift: dict[str, Any], focal_px: float) -> str:
    """The one-line warning of a view of :func:`view_shifts`, with the rotation its shift amounts to (``focal_px``:
    the focal length, pixels)."""
    du, dv = shift["shift_px"]
    deg = math.degrees(math.atan2(math.hypot(du, dv), focal_px))
    return (
        f"views[{shift['view']}]: the boxes of its {shift['n_objects']} objects seen in {MIN_VIEWS} or more views sit "
        f"{du:+.0f}, {dv:+.0f} px (u, v) from where the other views put them, about {deg:.1f} degrees: this view's pose "
        "or theirs may be off (check the poses' time stamps and the hand-eye calibration, or state the error: "
        "pose_sigma_mm, pose_sigma_deg; CLI --pose-sigma-mm, --pose-sigma-deg)"
    )


def centre_offsets(problem: Problem, obj: Found) -> tuple[list[int], NDArray[np.float64], NDArray[np.float64]]:
    """The session indices of the views an object holds a box in (K), the offsets (K, 2) of those boxes' centres from
    the centres its fitted model predicts, pixels, and the centres' noise (K, 2), pixels; NaN rows for a box on the
    image border."""
    views = sorted(obj.associations)
    poses, boxes = object_boxes(problem, obj)
    e = Ellipsoid(obj.position, obj.semi_axes, obj.quaternion_xyzw)  # type: ignore[arg-type]
    pred = solid_boxes(problem.camera, poses, e, obj.solid)
    offsets = 0.5 * (boxes[:, :2] + boxes[:, 2:]) - 0.5 * (pred[:, :2] + pred[:, 2:])
    sigma = box_edge_sigma_px(problem.model, pred)[:, :2] / math.sqrt(2.0)
    cam = problem.camera
    offsets[censored_edges(boxes, cam.width, cam.height, problem.model.border_px).any(axis=1)] = np.nan
    return views, offsets, sigma


def view_shifts(problem: Problem, objects: list[Found]) -> list[dict[str, Any]]:
    """The views whose boxes sit off together (see the module), in view order, each as ``view`` (its index in the
    session), ``shift_px`` ([u, v], pixels: the mean scaled offset of the observed box centres from the predicted ones
    times the centres' median noise), ``n_objects`` (M, the objects it was judged on) and ``chi2`` (``M |mean scaled
    offset|^2``)."""
    per_view: dict[int, list[tuple[NDArray[np.float64], NDArray[np.float64]]]] = {}
    for obj in objects:
        if len(obj.associations) < MIN_VIEWS or obj.semi_axes is None:
            continue
        for v, d, s in zip(*centre_offsets(problem, obj)):
            if np.all(np.isfinite(d)) and np.all(s > 0):
                per_view.setdefault(v, []).append((d, s))
    out = []
    for v in sorted(per_view):
        if len(per_view[v]) < MIN_OBJECTS:
            continue
        d, s = (np.array(a) for a in zip(*per_view[v]))
        scaled = np.clip(d / s, -CLIP_SIGMAS, CLIP_SIGMAS).mean(axis=0)
        chi2 = float(len(d) * scaled @ scaled)
        shift = scaled * np.median(s, axis=0)  # in pixels, robust to the one cut box the clip tamed
        if chi2 > CHI2_THRESHOLD and float(np.hypot(*shift)) >= MIN_SHIFT_PX:
            out.append({"view": v, "shift_px": [float(x) for x in shift], "n_objects": len(d), "chi2": chi2})
    return out


def shift_cause(shift: dict[str, Any], focal_px: float) -> Cause:
    """The :class:`~monovisual3d.verdict.Cause` (``view_disagrees``) of a view of :func:`view_shifts`, naming the view."""
    return Cause("view_disagrees", shift_message(shift, focal_px), "suspect", (int(shift["view"]),), dict(shift))


def run(problem: Problem, state: State) -> State:
    """The pass: the views whose boxes sit off together, in the state's diagnostics, each a ``view_disagrees`` cause."""
    shifts = view_shifts(problem, list(state.objects))
    focal = max(problem.camera.fx, problem.camera.fy)
    causes = tuple(shift_cause(s, focal) for s in shifts)
    return replace(state, view_shifts=tuple(shifts), causes=state.causes + causes)
