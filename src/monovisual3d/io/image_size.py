"""The camera for the image the boxes refer to: resized (stretched or cropped) or cropped calibrations."""

from __future__ import annotations

import re
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..camera import Camera
from ..checks import as_array, as_int
from ..errors import InputError, excerpt

RESIZE_MODES = ("auto", "stretch", "crop")
#: Image sizes (width, height) of common camera sensors and video modes, pixels (landscape; portrait is the same turned):
#: the candidates when a calibration gives a principal point but no image size.
STANDARD_IMAGE_SIZES = (
    (320, 240),
    (640, 360),
    (640, 400),
    (640, 480),
    (672, 376),
    (752, 480),
    (800, 600),
    (848, 480),
    (960, 540),
    (1024, 768),
    (1224, 1024),
    (1280, 720),
    (1280, 800),
    (1280, 960),
    (1280, 1024),
    (1440, 1080),
    (1456, 1088),
    (1600, 1200),
    (1920, 1080),
    (1920, 1200),
    (2048, 1536),
    (2448, 2048),
    (2560, 1440),
    (2592, 1944),
    (3840, 2160),
    (4096, 2160),
)
#: How far twice the principal point may lie from a standard size, as a fraction of each side, for that size to be
#: taken: a calibrated principal point lies within one or two per cent of the image centre (lens and sensor
#: misalignment), closer than most neighbouring standard sizes are to each other.
PRINCIPAL_POINT_TOL = 0.03
#: How far, pixels, a box may reach past the border of a candidate size that is still taken: hand-drawn and
#: detector boxes overshoot the border by a few pixels (one Aldoma box ends 5.4 px below its 480 px image).
BOX_OVERHANG_PX = 8.0


def camera_for_image_size(camera: Camera, image_size: tuple[int, int], resize: str = "auto") -> Camera:
    """The camera for images resized to ``image_size`` (the size the detections refer to).

    Parameters
    ----------
    camera : Camera, as calibrated
    image_size : (width, height), pixels
    resize : {"auto", "stretch", "crop"}
        ``stretch``: each axis scaled independently (:meth:`Camera.scaled`).
        ``crop``: scaled uniformly to cover ``image_size``, then centre-cropped
        (DepthAI ``getCameraIntrinsics(..., keepAspectRatio=True)``).
        ``auto``: ``stretch`` when the aspect ratios agree within one pixel,
        otherwise an error that asks for an explicit choice.

    Returns
    -------
    Camera with ``camera.size == image_size``

    Examples
    --------
    >>> cam = Camera(1280, 960, 1000.0, 1000.0, 640.0, 480.0)
    >>> camera_for_image_size(cam, (640, 480)).fx
    500.0
    """
    w, h = size_pair(image_size, "--image-size (image_size)")
    if resize not in RESIZE_MODES:
        raise InputError(f"--resize (resize): got {excerpt(resize)}, expected one of {list(RESIZE_MODES)}")
    W, H = camera.size
    if (w, h) == (W, H):
        return camera
    sx, sy = w / W, h / H
    if resize == "auto":
        if abs(sx - sy) * max(W, H) > 1.0:
            raise InputError(
                f"--image-size (image_size): the detections' {w}x{h} images and the {W}x{H} calibration differ in "
                "aspect ratio; say how the images were made: --resize stretch or --resize crop (centre crop) "
                "(resize='stretch' or 'crop'), or the region they were cut from with --crop X1,Y1,X2,Y2 (crop_xyxy)"
            )
        resize = "stretch"
    if resize == "stretch":
        return camera.scaled(w, h)
    s = max(sx, sy)
    ox, oy = 0.5 * (W * s - w), 0.5 * (H * s - h)
    return Camera(
        w,
        h,
        camera.fx * s,
        camera.fy * s,
        camera.cx * s - ox,
        camera.cy * s - oy,
        camera.distortion_model,
        camera.distortion_coefficients,
    )


def crop_camera(camera: Camera, crop_xyxy: ArrayLike) -> Camera:
    """The camera for a crop ``(x1, y1, x2, y2)`` (pixels, integers) of its image.

    Examples
    --------
    >>> crop_camera(Camera(640, 480, 500.0, 500.0, 320.0, 240.0), (100, 50, 420, 290)).cx
    220.0
    """
    box = as_array(crop_xyxy, "--crop (crop_xyxy)", size=4).ravel()
    x1, y1, x2, y2 = (as_int(v, f"--crop (crop_xyxy[{i}])") for i, v in enumerate(box))
    if not (0 <= x1 < x2 <= camera.width and 0 <= y1 < y2 <= camera.height):
        raise InputError(
            f"--crop (crop_xyxy): {[x1, y1, x2, y2]} is not a region inside the {camera.width}x{camera.height} image"
        )
    return Camera(
        x2 - x1,
        y2 - y1,
        camera.fx,
        camera.fy,
        camera.cx - x1,
        camera.cy - y1,
        camera.distortion_model,
        camera.distortion_coefficients,
    )


def image_size_from_principal_point(
    cx: float, cy: float, extent_px: tuple[float, float] = (0.0, 0.0)
) -> tuple[tuple[int, int], str]:
    """The image size a calibration's principal point ``(cx, cy)`` (pixels, centres at integer + 0.5) implies.

    The standard size (:data:`STANDARD_IMAGE_SIZES`, either way up) nearest ``(2 cx, 2 cy)`` among those within
    :data:`PRINCIPAL_POINT_TOL` of it on both sides (the larger relative deviation decides) that hold the boxes,
    ``extent_px`` = the largest ``(x2, y2)``, within :data:`BOX_OVERHANG_PX`; else ``(2 cx, 2 cy)`` rounded. Where the
    image border lies matters: a box edge on it is truncated and counts one-sided.

    Returns
    -------
    size : (width, height), pixels
    how : ``"exact"`` (twice the principal point is that standard size), ``"standard"`` (the nearest standard size)
        or ``"principal point"`` (no standard size fits: twice the principal point)

    Examples
    --------
    >>> image_size_from_principal_point(641.9, 364.2)
    ((1280, 720), 'standard')
    >>> image_size_from_principal_point(336.0, 188.0)
    ((672, 376), 'exact')
    >>> image_size_from_principal_point(500.0, 300.0)
    ((1000, 600), 'principal point')
    """
    w, h = 2.0 * cx, 2.0 * cy
    if not (np.isfinite(w) and np.isfinite(h)):
        raise InputError(f"principal point ({cx:g}, {cy:g}): expected finite pixel coordinates")
    landscape = np.array(STANDARD_IMAGE_SIZES, dtype=float)
    sizes = np.concatenate([landscape, landscape[:, ::-1]])
    off = np.max(np.abs(sizes - (w, h)) / sizes, axis=1)
    holds = np.all(sizes + BOX_OVERHANG_PX >= np.asarray(extent_px, dtype=float), axis=1)
    off = np.where(holds, off, np.inf)
    k = int(np.argmin(off))
    if off[k] <= PRINCIPAL_POINT_TOL:
        size = (int(sizes[k, 0]), int(sizes[k, 1]))
        return size, "exact" if size == (round(w), round(h)) else "standard"
    return (round(w), round(h)), "principal point"


def size_pair(size: Any, where: str) -> tuple[int, int]:
    """``(width, height)`` from a pair of positive integers, else one line naming ``where``."""
    if isinstance(size, (str, bytes)) or not hasattr(size, "__len__") or len(size) != 2:
        raise InputError(f"{where}: expected (width, height), got {excerpt(size)}")
    return as_int(size[0], f"{where}[0]", minimum=1), as_int(size[1], f"{where}[1]", minimum=1)


def parse_image_size(text: str) -> tuple[int, int]:
    """``"640x480"`` -> ``(640, 480)`` (also ``640,480``)."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX,]\s*(\d+)\s*", text)
    if not m:
        raise InputError(f"--image-size: got {excerpt(text)}, expected WIDTHxHEIGHT such as 640x480")
    return size_pair((int(m.group(1)), int(m.group(2))), "--image-size")
