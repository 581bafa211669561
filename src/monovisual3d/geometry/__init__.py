"""Projection geometry of objects: ellipsoids, their dual quadrics and image boxes.

- :mod:`~monovisual3d.geometry.ellipsoid`: the :class:`Ellipsoid`, its dual quadric, the projected
  conic, closed-form and contour-sampled boxes, volume;
- :mod:`~monovisual3d.geometry.bounds`: the Cramer-Rao bound of the box-edge model for ellipsoids;
- :mod:`~monovisual3d.geometry.fit`: a least-squares fit of an ellipsoid to associated boxes.

:mod:`monovisual3d.sphere` (the sphere special case) stays where it is for now.
"""

from __future__ import annotations

from .bounds import ShapeBound, centre_crlb_rms_sq, ellipsoid_crlb
from .ellipsoid import (
    SHAPES,
    Ellipsoid,
    bbox_from_dual_conic,
    dual_quadric,
    ellipsoid_bbox,
    ellipsoid_bbox_optical,
    ellipsoid_contour_optical,
    ellipsoid_contour_uv,
    ellipsoid_volume,
    equivalent_radius,
    projected_dual_conic,
    quaternion_xyzw_from_rotation,
    rotation_from_quaternion_xyzw,
    rotation_upright,
    shape_of,
    silhouette_distance_px,
)
from .fit import EllipsoidFit, fit_ellipsoid_boxes, fit_ellipsoid_to_boxes, fit_shape_by_bic

__all__ = [
    "SHAPES",
    "Ellipsoid",
    "EllipsoidFit",
    "ShapeBound",
    "bbox_from_dual_conic",
    "centre_crlb_rms_sq",
    "dual_quadric",
    "ellipsoid_bbox",
    "ellipsoid_bbox_optical",
    "ellipsoid_contour_optical",
    "ellipsoid_contour_uv",
    "ellipsoid_crlb",
    "ellipsoid_volume",
    "equivalent_radius",
    "fit_ellipsoid_boxes",
    "fit_ellipsoid_to_boxes",
    "fit_shape_by_bic",
    "projected_dual_conic",
    "quaternion_xyzw_from_rotation",
    "rotation_from_quaternion_xyzw",
    "rotation_upright",
    "shape_of",
    "silhouette_distance_px",
]
