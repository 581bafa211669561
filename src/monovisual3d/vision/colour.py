"""Colour detector: red fruit in RGB images as boxes (extra ``[vision]``, OpenCV).

The pipeline, each step a function:

1. :func:`colour_mask_from_rgb` -- HSV threshold: hue inside any of
   ``hue_ranges_deg`` (red wraps around 0 degrees, hence two ranges), saturation
   and value above their minima; then a morphological opening (removes speckle)
   and closing (bridges one-pixel gaps), and hole filling (specular highlights).
2. :func:`detections_from_mask` -- 8-connected components; each component of at
   least ``min_area_px`` pixels gives one :class:`~monovisual3d.session.Detection`
   whose box covers its pixels in the project's edge convention (pixel columns
   10..19 give ``x1 = 10, x2 = 20``).
3. :func:`detect_colour` -- both steps.

Score: ``min(1, fill / (pi / 4)) * area / (area + min_area_px)``, where ``fill`` is
the component's area over its box area: a full disc well above the minimum size
scores close to 1; ragged, partly hidden or tiny blobs score lower.

Limitation: touching or overlapping fruit of the same colour merge into one
component and hence one box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._extras import require
from ..checks import is_int
from ..errors import InputError
from ..session import Detection


@dataclass(frozen=True)
class ColourDetectorConfig:
    """Options of the colour detector.

    Attributes
    ----------
    hue_ranges_deg : tuple of (low, high) pairs, degrees in [0, 360], inclusive; red is
        ``((0, 20), (340, 360))``
    saturation_min, value_min : float in [0, 1], HSV saturation and value thresholds
    open_px, close_px : int, side of the elliptical structuring elements of the opening
        and closing, pixels (0 or 1 skips the step)
    fill_holes : bool, fill holes inside blobs (does not change boxes, only the score)
    min_area_px : int, smaller components are dropped
    label : str or None, label given to the detections
    """

    hue_ranges_deg: tuple[tuple[float, float], ...] = ((0.0, 20.0), (340.0, 360.0))
    saturation_min: float = 0.45
    value_min: float = 0.15
    open_px: int = 3
    close_px: int = 3
    fill_holes: bool = True
    min_area_px: int = 20
    label: str | None = "fruit"

    def __post_init__(self) -> None:
        if not self.hue_ranges_deg:
            raise InputError("hue_ranges_deg: empty, expected at least one (low, high) pair in degrees")
        for i, pair in enumerate(self.hue_ranges_deg):
            if len(pair) != 2 or not 0 <= pair[0] <= pair[1] <= 360:
                raise InputError(f"hue_ranges_deg[{i}]: got {pair!r}, expected (low, high) with 0 <= low <= high <= 360 degrees")
        for name in ("saturation_min", "value_min"):
            value = getattr(self, name)
            if not 0 <= value <= 1:
                raise InputError(f"{name}: got {value}, expected a fraction in [0, 1]")
        for name in ("open_px", "close_px", "min_area_px"):
            value = getattr(self, name)
            if not is_int(value) or value < 0:
                raise InputError(f"{name}: got {value!r}, expected a non-negative integer (pixels)")


def check_rgb_image(image_rgb: ArrayLike, where: str = "image_rgb") -> NDArray[np.uint8]:
    """Validate an RGB image, shape (height, width, 3), uint8, and return it C-contiguous."""
    img = np.asarray(image_rgb)
    if img.ndim != 3 or img.shape[2] != 3:
        raise InputError(f"{where}: expected an RGB image of shape (height, width, 3), got {list(img.shape)}")
    if img.dtype != np.uint8:
        raise InputError(f"{where}: expected dtype uint8 (0..255), got {img.dtype}")
    return np.ascontiguousarray(img)


def colour_mask_from_rgb(image_rgb: ArrayLike, config: ColourDetectorConfig | None = None) -> NDArray[np.bool_]:
    """Pixels of the target colour after morphological cleanup.

    Parameters
    ----------
    image_rgb : array_like, shape (height, width, 3), uint8, RGB order
    config : ColourDetectorConfig or None (red fruit)

    Returns
    -------
    mask : ndarray, shape (height, width), bool

    Examples
    --------
    >>> img = np.zeros((20, 30, 3), np.uint8)
    >>> img[5:15, 10:20] = (200, 20, 10)
    >>> int(colour_mask_from_rgb(img).sum())  # the opening rounds off the four corner pixels
    96
    """
    cv2 = require("cv2", "vision")
    cfg = config or ColourDetectorConfig()
    img = check_rgb_image(image_rgb)
    hsv = cv2.cvtColor(img, cv2.COLOR_RGB2HSV_FULL)  # hue 0..255 for 0..360 degrees
    hue_deg = hsv[..., 0].astype(np.float32) * (360.0 / 256.0)
    hue_ok = np.zeros(img.shape[:2], dtype=bool)
    for low, high in cfg.hue_ranges_deg:
        hue_ok |= (hue_deg >= low) & (hue_deg <= high)
    mask = hue_ok & (hsv[..., 1] >= 255.0 * cfg.saturation_min) & (hsv[..., 2] >= 255.0 * cfg.value_min)
    m = mask.astype(np.uint8)
    if cfg.open_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (cfg.open_px, cfg.open_px)))
    if cfg.close_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (cfg.close_px, cfg.close_px)))
    mask = m.astype(bool)
    if cfg.fill_holes:
        mask = fill_holes(mask)
    return mask


def fill_holes(mask: ArrayLike) -> NDArray[np.bool_]:
    """Fill background regions of a mask (H, W) that do not touch the image border."""
    cv2 = require("cv2", "vision")
    m = np.asarray(mask, dtype=bool)
    n, lab = cv2.connectedComponents((~m).astype(np.uint8), connectivity=4)
    border = np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))
    hole = ~np.isin(lab, border) & ~m
    return m | hole


def detections_from_mask(mask: ArrayLike, config: ColourDetectorConfig | None = None) -> list[Detection]:
    """One detection per 8-connected component of a mask, highest score first.

    Parameters
    ----------
    mask : array_like, shape (height, width), bool
    config : ColourDetectorConfig or None (uses ``min_area_px`` and ``label``)

    Returns
    -------
    detections : list of Detection, boxes in pixels (edge convention)

    Examples
    --------
    >>> m = np.zeros((20, 30), bool)
    >>> m[5:15, 10:20] = True
    >>> detections_from_mask(m)[0].bbox_xyxy
    array([10.,  5., 20., 15.])
    """
    cv2 = require("cv2", "vision")
    cfg = config or ColourDetectorConfig()
    m = np.asarray(mask)
    if m.ndim != 2:
        raise InputError(f"mask: expected a (height, width) image, got shape {list(m.shape)}")
    n, _, stats, _ = cv2.connectedComponentsWithStats(m.astype(bool).astype(np.uint8), connectivity=8)
    dets: list[Detection] = []
    for k in range(1, n):
        x, y, w, h, area = (int(v) for v in stats[k, :5])
        if area < max(cfg.min_area_px, 1):
            continue
        fill = area / float(w * h)
        score = min(1.0, fill / (math.pi / 4.0)) * area / (area + cfg.min_area_px)
        box = np.array([x, y, x + w, y + h], dtype=float)
        dets.append(Detection(bbox_xyxy=box, score=float(score), label=cfg.label))
    dets.sort(key=lambda d: -(d.score or 0.0))
    return dets


def detect_colour(image_rgb: ArrayLike, config: ColourDetectorConfig | None = None) -> list[Detection]:
    """Detect blobs of the target colour (red fruit by default) in an RGB image.

    Parameters
    ----------
    image_rgb : array_like, shape (height, width, 3), uint8, RGB order
    config : ColourDetectorConfig or None

    Returns
    -------
    detections : list of Detection, highest score first

    Examples
    --------
    >>> img = np.full((40, 60, 3), 90, np.uint8)
    >>> img[10:30, 20:44] = (210, 25, 20)
    >>> [d.bbox_xyxy.tolist() for d in detect_colour(img)]
    [[20.0, 10.0, 44.0, 30.0]]
    """
    cfg = config or ColourDetectorConfig()
    return detections_from_mask(colour_mask_from_rgb(image_rgb, cfg), cfg)
