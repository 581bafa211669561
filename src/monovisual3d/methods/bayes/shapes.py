"""The shape stage: each object as a sphere, spheroid or ellipsoid (``BayesConfig.shape``).

The search, extraction and association run with spheres and upright spheroids
(``BayesConfig.elongations``), so a tall box is found and associated as what it
is. This stage then refines the shape: it fits each object's associated boxes with the shape
model (:func:`monovisual3d.geometry.fit.fit_shape_by_bic`, robust, truncated
edges left out):

- ``sphere``: the sphere estimate is kept (the shape fields are filled in);
- ``spheroid`` / ``ellipsoid``: that model is fitted;
- ``auto`` (default): round-looking objects stay spheres without a fit; an
  object whose boxes are elongated the same way in every view (:func:`looks_round`) is
  fitted as sphere, spheroid and (with at least
  :data:`MIN_VIEWS_FOR_ELLIPSOID` views) ellipsoid, and the model with the
  lowest BIC is kept.
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
#: ``auto`` fits shapes when log(box aspect / sphere's predicted aspect) exceeds this, with one sign, in at least two
#: boxes not cut by the image border (one truncated or occluded box does not make a fruit elongated).
ROUNDNESS_THRESHOLD = 0.08


def _boxes(problem: Problem, obj: DetectedObject) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The object's poses ``T_base_optical`` (K, 4, 4) and associated boxes (K, 4)."""
    by_index = {vd.index: vd for vd in problem.views}
    items = sorted(obj.associations.items())
    poses = np.array([invert_transform(by_index[v].T_optical_base) for v, _ in items]).reshape(-1, 4, 4)
    boxes = np.array([by_index[v].boxes[j] for v, j in items]).reshape(-1, 4)
    return poses, boxes


def looks_round(problem: Problem, obj: DetectedObject) -> bool:
    """Whether the object's untruncated boxes have the aspect its sphere predicts (within the threshold)."""
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
    # a non-round fruit is elongated the same way in every view; occlusion truncates one view's box at random
    d = np.asarray(deviations)
    consistent = len(d) >= 2 and (np.all(d > ROUNDNESS_THRESHOLD) or np.all(d < -ROUNDNESS_THRESHOLD))
    return not consistent


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
    if cfg.shape == "auto":
        shapes: tuple[str, ...] = ("sphere", "spheroid") + (("ellipsoid",) if len(boxes) >= MIN_VIEWS_FOR_ELLIPSOID else ())
    else:
        shapes = (cfg.shape,)
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
