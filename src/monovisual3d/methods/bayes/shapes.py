"""The shape stage: each object as a sphere, spheroid or ellipsoid (``BayesConfig.shape``).

The search, extraction and association run with spheres and upright spheroids
(``BayesConfig.elongations``), so a tall box is found and associated as what it
is. This stage then refines the shape: it fits each object's associated boxes with the shape
model (:func:`monovisual3d.geometry.fit.fit_shape_by_bic`, robust, truncated
edges left out):

- ``sphere``: the sphere estimate is kept (the shape fields are filled in);
- ``spheroid`` / ``ellipsoid``: that model is fitted;
- ``auto`` (default): round-looking objects stay spheres without a fit; an
  object whose boxes are not square in two or more views (:func:`looks_round`) is
  fitted as sphere, spheroid and (with at least :data:`MIN_VIEWS_FOR_ELLIPSOID`
  views, or :data:`MIN_VIEWS_FOR_LYING` when it looks lying: :func:`auto_shapes`)
  ellipsoid, and the model with the lowest BIC is kept.

Lying objects (a can, a box or a cucumber on its side: the long axis horizontal) are
the ``ellipsoid`` model (two horizontal semi-axes and a yaw). Their boxes are wide
where the camera sees them broadside and tall where it looks along the long axis
from above, so the sign of their elongation changes with the view; an upright
object's does not.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...errors import InputError
from ...frames import invert_transform
from ...geometry.sphere import predict_sphere_boxes
from ...result import DetectedObject
from .problem import Problem

#: Views an object needs before ``auto`` also tries the three-axis ellipsoid (it is weakly determined from fewer).
MIN_VIEWS_FOR_ELLIPSOID = 4
#: Views from which ``auto`` tries the ellipsoid for an object with a box wider than its sphere's: its horizontal
#: extent exceeds its height, it lies (a can, a box, a cucumber on its side), and its horizontal outline is not
#: the circle of an upright object. Three views give 12 box edges, each a plane tangent to the object, for the
#: ellipsoid's 7 parameters (upright axis, two horizontal semi-axes, yaw; a lying 5 x 5 x 12 cm object from
#: three views: tests/methods/bayes/test_bayes_shapes.py). An object taller than its sphere in every elongated
#: box stands upright, and three views keep it a sphere or spheroid (its horizontal outline is round).
MIN_VIEWS_FOR_LYING = 3
#: ``auto`` fits shapes when |log(box aspect / sphere's predicted aspect)| exceeds this in at least
#: :data:`MIN_ELONGATED_BOXES` boxes not cut by the image border.
ROUNDNESS_THRESHOLD = 0.08
#: Boxes that must be elongated before ``auto`` fits shapes: one truncated or occluded box does not make a fruit
#: elongated. The sign is not required to agree: an upright object is elongated the same way in every view, a
#: lying one wide broadside and tall end-on (see the module docstring).
MIN_ELONGATED_BOXES = 2


def _boxes(problem: Problem, obj: DetectedObject) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The object's poses ``T_base_optical`` (K, 4, 4) and associated boxes (K, 4)."""
    by_index = {vd.index: vd for vd in problem.views}
    items = sorted(obj.associations.items())
    poses = np.array([invert_transform(by_index[v].T_optical_base) for v, _ in items]).reshape(-1, 4, 4)
    boxes = np.array([by_index[v].boxes[j] for v, j in items]).reshape(-1, 4)
    return poses, boxes


def aspect_deviations(problem: Problem, obj: DetectedObject) -> NDArray[np.float64]:
    """``log(box aspect / aspect of the object's sphere's predicted box)`` of each associated box not cut by the image
    border, shape (K,) (aspect: height / width; positive: taller than the sphere's box)."""
    cam, border = problem.camera, problem.model.border_px
    by_index = {vd.index: vd for vd in problem.views}
    deviations = []
    for v, j in obj.associations.items():
        vd = by_index[v]
        x1, y1, x2, y2 = vd.boxes[j]
        if x1 <= border or y1 <= border or x2 >= cam.width - border or y2 >= cam.height - border:
            continue
        p_opt = vd.T_optical_base[:3, :3] @ obj.position + vd.T_optical_base[:3, 3]
        px1, py1, px2, py2 = predict_sphere_boxes(cam, p_opt[None, :], np.array([float(obj.radius)]))[0][0, 0]
        if not np.all(np.isfinite([px1, py1, px2, py2])) or min(x2 - x1, y2 - y1) <= 0:
            continue
        deviations.append(np.log((y2 - y1) / (x2 - x1)) - np.log((py2 - py1) / (px2 - px1)))
    return np.asarray(deviations, dtype=float)


def looks_round(problem: Problem, obj: DetectedObject) -> bool:
    """Whether the object's untruncated boxes have the aspect its sphere predicts: fewer than
    :data:`MIN_ELONGATED_BOXES` of them deviate from it by more than :data:`ROUNDNESS_THRESHOLD`, of either sign."""
    # an upright object deviates with one sign in every view, a lying one with the sign its azimuth gives;
    # occlusion truncates one view's box at random
    return int(np.sum(np.abs(aspect_deviations(problem, obj)) > ROUNDNESS_THRESHOLD)) < MIN_ELONGATED_BOXES


def auto_shapes(deviations: NDArray[np.floating], n_views: int) -> tuple[str, ...]:
    """The models ``auto`` compares for an object that does not look round, given its :func:`aspect_deviations`
    and its number of views: sphere and spheroid; the ellipsoid too from :data:`MIN_VIEWS_FOR_ELLIPSOID` views, or
    from :data:`MIN_VIEWS_FOR_LYING` when a box is wider than the sphere's (a lying object).

    Examples
    --------
    >>> auto_shapes(np.array([0.3, 0.25, 0.4]), 3)  # taller in every view: upright
    ('sphere', 'spheroid')
    >>> auto_shapes(np.array([0.3, -0.2, 0.0]), 3)  # wider in one view: lying
    ('sphere', 'spheroid', 'ellipsoid')
    """
    wide = bool(np.any(np.asarray(deviations, dtype=float) < -ROUNDNESS_THRESHOLD))
    ellipsoid = n_views >= MIN_VIEWS_FOR_ELLIPSOID or (wide and n_views >= MIN_VIEWS_FOR_LYING)
    return ("sphere", "spheroid") + (("ellipsoid",) if ellipsoid else ())


def as_sphere(obj: DetectedObject) -> DetectedObject:
    """The sphere estimate with its shape fields filled in (an upright spheroid of the search: its
    volume-equivalent radius)."""
    r = float(obj.radius)  # type: ignore[arg-type]
    b = obj.extra.get("semi_up")
    if b is not None:
        r = float((r * r * float(b)) ** (1 / 3))
    return DetectedObject(
        obj.position, obj.score, r, obj.covariance, obj.associations, obj.n_cells, obj.extra,
        shape="sphere", semi_axes=np.array([r, r, r]), quaternion_xyzw=np.array([0.0, 0.0, 0.0, 1.0]),
    )  # fmt: skip


def fit_shape(problem: Problem, obj: DetectedObject) -> DetectedObject:
    """One object through the shape stage (see the module docstring)."""
    from ...geometry.fit import fit_shape_by_bic

    cfg = problem.config
    poses, boxes = _boxes(problem, obj)
    if cfg.shape == "sphere" or len(boxes) < 2 or (cfg.shape == "auto" and looks_round(problem, obj)):
        return as_sphere(obj)
    shapes = auto_shapes(aspect_deviations(problem, obj), len(boxes)) if cfg.shape == "auto" else (cfg.shape,)
    try:
        best, _ = fit_shape_by_bic(
            problem.camera, poses, boxes, shapes=shapes, up=cfg.up_vector, size_range=cfg.semi_axis_range,
            box_sigma=problem.model.alpha, edge_sigma_px=problem.model.sigma0_px, border_px=problem.model.border_px,
            free_orientation=cfg.free_orientation,
        )  # fmt: skip
    except InputError:  # too few usable edges for any model: keep the sphere
        return as_sphere(obj)
    if best.model == "sphere" and cfg.shape == "auto" and obj.extra.get("semi_up") is None:
        return as_sphere(obj)  # the sphere refinement (masks, pose noise) is the better sphere estimate
    e = best.ellipsoid
    extra = {**obj.extra, "shape_bic": float(best.bic), "shape_rms_px": float(best.rms_px)}
    return DetectedObject.from_ellipsoid(
        e.centre_base, e.semi_axes, e.quaternion_xyzw, obj.score, best.model,
        covariance=best.centre_covariance, associations=obj.associations, n_cells=obj.n_cells, extra=extra,
    )  # fmt: skip


def shape_stage(problem: Problem, objects: list[DetectedObject]) -> list[DetectedObject]:
    """Every object through :func:`fit_shape`."""
    return [fit_shape(problem, o) for o in objects]
