"""Former home of the sphere geometry, kept for compatibility: see :mod:`monovisual3d.geometry.sphere`."""

from .geometry.sphere import clip_boxes, pinhole_sphere_boxes, predict_sphere_boxes, sphere_bbox, sphere_bbox_optical

__all__ = ["clip_boxes", "pinhole_sphere_boxes", "predict_sphere_boxes", "sphere_bbox", "sphere_bbox_optical"]
