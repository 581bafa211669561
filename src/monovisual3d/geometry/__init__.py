"""The one home of projection geometry: where objects (spheres, ellipsoids) appear in images.

- :mod:`.sphere`: the sphere's exact box, the ``bayes`` likelihood's box model and the algebraic pinhole box;
- :mod:`.spheroid`: the box of an upright spheroid in closed form (the ``bayes`` search's elongated hypotheses);
- :mod:`.ellipsoid`: the :class:`Ellipsoid`, closed-form and contour-sampled boxes, silhouette, volume;
- :mod:`.solids`: the exact boxes of upright cylinders (their two rim circles) and cuboids (their corners);
- :mod:`.quadric`: the dual quadric and back (the ellipsoid of a dual quadric), the projected dual conic, the box of a conic;
- :mod:`.orientation`: the "upright" rotation and quaternions;
- :mod:`.bounds`: the Cramer-Rao bound of the box-edge model for ellipsoids;
- :mod:`.fit`: a least-squares fit of a sphere, spheroid, ellipsoid, cylinder or cuboid to associated boxes.

The compiled kernels are tested against these. Names load on first use (the fit needs scipy).
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "ShapeBound": "bounds",
    "centre_crlb_rms_sq": "bounds",
    "ellipsoid_crlb": "bounds",
    "SHAPES": "ellipsoid",
    "Ellipsoid": "ellipsoid",
    "bbox_from_dual_conic": "quadric",
    "dual_quadric": "quadric",
    "ellipsoid_from_dual_quadric": "quadric",
    "ellipsoid_bbox": "ellipsoid",
    "ellipsoid_bbox_optical": "ellipsoid",
    "ellipsoid_contour_optical": "ellipsoid",
    "ellipsoid_contour_uv": "ellipsoid",
    "ellipsoid_volume": "ellipsoid",
    "equivalent_radius": "ellipsoid",
    "projected_dual_conic": "quadric",
    "quaternion_xyzw_from_rotation": "orientation",
    "rotation_from_quaternion_xyzw": "orientation",
    "rotation_upright": "orientation",
    "shape_of": "ellipsoid",
    "silhouette_distance_px": "ellipsoid",
    "EllipsoidFit": "fit",
    "fit_ellipsoid_boxes": "fit",
    "fit_ellipsoid_to_boxes": "fit",
    "fit_shape_by_bic": "fit",
    "clip_boxes": "sphere",
    "pinhole_sphere_boxes": "sphere",
    "predict_sphere_boxes": "sphere",
    "sphere_bbox": "sphere",
    "sphere_bbox_optical": "sphere",
    "predict_spheroid_boxes": "spheroid",
    "SOLIDS": "solids",
    "circle_bbox_optical": "solids",
    "cuboid_bbox": "solids",
    "cylinder_bbox": "solids",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
