"""Image processing: a colour detector for red fruit (extra ``[vision]``) and box helpers.

:mod:`monovisual3d.vision.boxes` needs numpy only; :mod:`monovisual3d.vision.colour`
imports OpenCV when a detector function is called.
"""

from __future__ import annotations

from .boxes import box_iou, boxes_from_label_image, match_boxes
from .colour import ColourDetectorConfig, colour_mask_from_rgb, detect_colour, detections_from_mask, fill_holes

__all__ = [
    "ColourDetectorConfig",
    "box_iou",
    "boxes_from_label_image",
    "colour_mask_from_rgb",
    "detect_colour",
    "detections_from_mask",
    "fill_holes",
    "match_boxes",
]
