"""What an object's boxes show of its shape before any fit: their aspects and edges against its sphere's.

The shape stage (:mod:`.shapes`) asks these questions of each object the search found as a sphere (or an upright
spheroid) before it fits shapes: are its boxes round (:func:`looks_round`), elongated one way in every view
(:func:`elongated_one_way`) and alike (:func:`consistently_elongated`), or is one box elongated far beyond box noise
(:func:`strongly_elongated`); does an edge stick out of its sphere's predicted box (:func:`sticks_out`: no occluder
makes a box larger) or lie deep inside it (:func:`possibly_cut`: an occluder the search does not see may have cut it).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...frames import invert_transform
from ...geometry.ellipsoid import Ellipsoid, ellipsoid_bbox
from ...geometry.solids import cuboid_bbox, cylinder_bbox
from ...geometry.sphere import predict_sphere_boxes
from .problem import Problem
from .sensor import box_edge_sigma_px, censored_edges, inward_edge_offsets
from .state import Found

#: ``auto`` fits shapes when |log(box aspect / sphere's predicted aspect)| exceeds this in at least
#: :data:`MIN_ELONGATED_BOXES` boxes not cut by the image border, and in at least :data:`MIN_ELONGATED_FRACTION` of them.
ROUNDNESS_THRESHOLD = 0.08
#: Boxes that must be elongated before ``auto`` fits shapes: one truncated or occluded box does not make a fruit
#: elongated. The sign is not required to agree: an upright object is elongated the same way in every view, a
#: lying one wide broadside and tall end-on (see the module docstring).
MIN_ELONGATED_BOXES = 2
#: Share of the measured boxes that must be elongated as well. The threshold is 1.33 sigmas of the log aspect under
#: 3 % edge noise (sigma = 2 x 0.03: two edges per side, two sides), which a round fruit's box passes by chance 18 % of
#: the time: two of three boxes 9 % of the time, but two of five 23 % and two of eight 44 %, so that a fixed count sent
#: more round fruit through the shape fits the more views saw them (in a 96-fruit row from 5 views, a few per row, about
#: 10 % of the run). Half of them keeps the chance at 9 % (3 views), 15 % (4), 5 % (5) and 4 % (8), and leaves every
#: object seen in 3 or 4 views as it was; an elongated object's boxes are elongated in most views (a lying one is round
#: only where the camera looks at it at about 45 degrees).
MIN_ELONGATED_FRACTION = 0.5
#: ``auto`` also tries the lying fits (:func:`.shapes.beats` must prefer them to the sphere) for an object with a single
#: elongated box when that box's |log(aspect / sphere's aspect)| exceeds this: a 35 % difference, 3 sigmas of the log
#: aspect under 5 % edge noise (sigma = 2 x 0.05), 5 under 3 %; a shape or a cut, not noise. A flat object (a tray) seen
#: from above in two views and from 20 degrees in a third has two round boxes and one wide one, which kept a sphere
#: takes the wide box as cut top and bottom. A sphere a leaf cuts stays a sphere: the sensor model explains the cut
#: (why: docs/decisions/bayes-shapes.md#strong_elongation).
STRONG_ELONGATION = 0.3
#: An edge of an object's box this many sensor sigmas inside its sphere's prediction may be cut by an occluder the
#: search does not see (a leaf): an object elongated one way with such an edge, and with boxes elongated unlike each
#: other (:func:`consistently_elongated`: a cut changes the boxes it cuts, a shape all of them), takes a fitted shape
#: only when that beats the sphere under the sensor model (:func:`possibly_cut`, :func:`.shapes.beats`), as when a nearer object
#: cuts it. Box noise alone puts an edge there 0.13 % of the time. The second condition keeps an elongated object's
#: shape: a cucumber the search found as a sphere of its height has its boxes far inside that sphere's on both sides in
#: every view alike, which the sensor model scores as occlusion at ``inward_floor`` an edge. Asked of every fitted
#: object, the test would make a mildly elongated fruit's shape harder to take from exact boxes, under the sensor
#: model's pose noise and 5 % edge noise (why: docs/decisions/bayes-occlusion.md#hidden_cut_sigmas).
HIDDEN_CUT_SIGMAS = 3.0
#: An edge of an object's box this many sensor sigmas outside its sphere's prediction cannot be a cut (occlusion only
#: shrinks a box); box noise puts an edge there 0.13 % of the time (1.6 % for one of three views' 12 edges): an object
#: with an elongated box and such an edge (on any of its boxes) is fitted as the objects with two elongated boxes are
#: (:func:`sticks_out`). A box lying on a table, seen broadside in one of three views and end-on (square) in the two
#: others, has one elongated box, and edges of it outside the sphere's box (why: docs/decisions/bayes-shapes.md#outside_sigmas).
OUTSIDE_SIGMAS = 3.0


def object_boxes(problem: Problem, obj: Found) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The object's poses ``T_base_optical`` (K, 4, 4) and associated boxes (K, 4)."""
    items = sorted(obj.associations.items())
    views = [problem.view_at(v) for v, _ in items]
    poses = np.array([invert_transform(vd.T_optical_base) for vd in views]).reshape(-1, 4, 4)
    boxes = np.array([vd.boxes[j] for vd, (_, j) in zip(views, items)]).reshape(-1, 4)
    return poses, boxes


def aspect_deviations(problem: Problem, obj: Found, cut: frozenset[int] = frozenset()) -> NDArray[np.float64]:
    """``log(box aspect / aspect of the object's sphere's predicted box)`` of each associated box not cut by the image
    border nor in the views ``cut`` (session view indices: a nearer object cuts the box there), shape (K,) (aspect:
    height / width; positive: taller than the sphere's box). A cut box shows the cut, not the object's aspect."""
    cam, border = problem.camera, problem.model.border_px
    views = [(problem.view_at(v), j) for v, j in obj.associations.items() if v not in cut]
    seen = [(vd, vd.boxes[j]) for vd, j in views]
    seen = [(vd, b) for vd, b in seen if not censored_edges(np.asarray(b), cam.width, cam.height, border).any()]
    if not seen:
        return np.zeros(0)
    boxes = np.array([b for _, b in seen])
    p_opt = np.array([vd.T_optical_base[:3, :3] @ obj.position + vd.T_optical_base[:3, 3] for vd, _ in seen])
    pred = predict_sphere_boxes(cam, p_opt, np.full((len(seen), 1), float(obj.radius)))[0][:, 0]  # (K, 4)
    w, h = boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]
    ok = np.all(np.isfinite(pred), axis=1) & (np.minimum(w, h) > 0)
    pred = pred[ok]
    return np.log(h[ok] / w[ok]) - np.log((pred[:, 3] - pred[:, 1]) / (pred[:, 2] - pred[:, 0]))


def looks_round(problem: Problem, obj: Found, cut: frozenset[int] = frozenset()) -> bool:
    """Whether the object's untruncated boxes (leaving out the views ``cut``) have the aspect its sphere predicts
    (:func:`round_aspects` of their :func:`aspect_deviations`)."""
    return round_aspects(aspect_deviations(problem, obj, cut))


def round_aspects(deviations: NDArray[np.floating]) -> bool:
    """Whether boxes with these :func:`aspect_deviations` look round: fewer than :data:`MIN_ELONGATED_BOXES` of them, or
    fewer than :data:`MIN_ELONGATED_FRACTION` of them, deviate by more than :data:`ROUNDNESS_THRESHOLD`, of either sign.

    Examples
    --------
    >>> round_aspects(np.array([0.12, 0.01, -0.03, 0.10, 0.02]))  # two of five: noise
    True
    >>> round_aspects(np.array([0.12, 0.01, 0.10]))  # two of three
    False
    """
    d = np.abs(np.asarray(deviations, dtype=float))
    n = int(np.sum(d > ROUNDNESS_THRESHOLD))
    return n < MIN_ELONGATED_BOXES or n < MIN_ELONGATED_FRACTION * len(d)


def strongly_elongated(deviations: NDArray[np.floating]) -> bool:
    """Whether a box's aspect differs from its sphere's by more than :data:`STRONG_ELONGATION` (box noise does not do
    that; a shape or a cut does).

    Examples
    --------
    >>> strongly_elongated(np.array([0.06, -0.07, -0.88]))  # a tray from above twice, from 20 degrees once
    True
    >>> strongly_elongated(np.array([0.12, 0.01, -0.2]))  # noise, or a mildly elongated fruit
    False
    """
    return bool(np.any(np.abs(np.asarray(deviations, dtype=float)) > STRONG_ELONGATION))


def elongated_one_way(deviations: NDArray[np.floating]) -> bool:
    """Whether at least two boxes are elongated, all the same way (taller, or all wider, than the sphere's)."""
    d = np.asarray(deviations, dtype=float)
    return len(d) >= 2 and bool(np.all(d > ROUNDNESS_THRESHOLD) or np.all(d < -ROUNDNESS_THRESHOLD))


def consistently_elongated(deviations: NDArray[np.floating]) -> bool:
    """Whether the boxes' :func:`aspect_deviations` agree from view to view: their spread (largest minus smallest) is
    below the magnitude of their median. An upright object is elongated about equally in every view; a cut changes the
    aspect of the boxes it cuts only.

    Examples
    --------
    >>> consistently_elongated(np.array([1.33, 1.11, 1.41]))  # a cucumber
    True
    >>> consistently_elongated(np.array([0.29, 0.09, 1.51]))  # a tomato a leaf cuts to a sliver in one view
    False
    """
    d = np.asarray(deviations, dtype=float)
    return len(d) >= 2 and float(np.ptp(d)) < abs(float(np.median(d)))


def sticks_out(problem: Problem, obj: Found) -> bool:
    """Whether an edge of the object's boxes (not at the image border) lies more than :data:`OUTSIDE_SIGMAS` edge
    sigmas outside its sphere's predicted box: no occluder makes a box larger, so the sphere is the wrong shape there."""
    return bool(np.any(_edge_depths(problem, obj) < -OUTSIDE_SIGMAS))


def _edge_depths(problem: Problem, obj: Found) -> NDArray[np.float64]:
    """How far each edge of the object's boxes (K, 4) lies inside its sphere's predicted box, in edge sigmas
    (negative: outside; NaN at the image border, where a box is truncated)."""
    poses, boxes = object_boxes(problem, obj)
    o = as_sphere(obj)
    pred = solid_boxes(problem.camera, poses, Ellipsoid.sphere(o.position, float(o.radius)))  # type: ignore[arg-type]
    cam = problem.camera
    at_border = censored_edges(boxes, cam.width, cam.height, problem.model.border_px)
    depth = inward_edge_offsets(pred, boxes) / box_edge_sigma_px(problem.model, pred)
    return np.where(at_border, np.nan, depth)


def possibly_cut(problem: Problem, obj: Found) -> bool:
    """Whether an edge of the object's boxes (not at the image border) lies more than :data:`HIDDEN_CUT_SIGMAS` edge
    sigmas inside its sphere's predicted box: an occluder the search does not see (a leaf) may have cut it there."""
    return bool(np.any(_edge_depths(problem, obj) > HIDDEN_CUT_SIGMAS))


def solid_boxes(camera: Camera, poses: NDArray[np.float64], e: Ellipsoid, solid: str | None = None) -> NDArray[np.float64]:
    """Unclipped boxes (K, 4), pixels, seen from ``poses`` (K, 4, 4) of the ellipsoid ``e``, or with ``solid``
    (``cylinder``, ``cuboid``) of that solid with ``e``'s centre, semi-axes (radius or half-sides) and rotation."""
    if solid == "cylinder":
        return cylinder_bbox(camera, poses, e.centre_base, e.semi_axes[0], e.semi_axes[2], e.rotation)
    if solid == "cuboid":
        return cuboid_bbox(camera, poses, e.centre_base, e.semi_axes, e.rotation)
    return ellipsoid_bbox(camera, poses, e.centre_base, e.semi_axes, e.rotation, clip=False)


def as_sphere(obj: Found) -> Found:
    """The sphere estimate with its shape fields filled in (an upright spheroid of the search: its
    volume-equivalent radius)."""
    r = float(obj.radius)  # type: ignore[arg-type]
    b = obj.semi_up
    if b is not None:
        r = float((r * r * float(b)) ** (1 / 3))
    return Found(
        obj.position,
        obj.score,
        r,
        obj.covariance,
        obj.associations,
        obj.n_cells,
        shape="sphere",
        semi_axes=np.array([r, r, r]),
        quaternion_xyzw=np.array([0.0, 0.0, 0.0, 1.0]),
        **obj.learned(),
    )
