"""The camera for the image the boxes refer to: resized (stretched or cropped) or cropped calibrations."""

from __future__ import annotations

import re
from typing import Any

from numpy.typing import ArrayLike

from ..camera import Camera
from ..checks import as_array, as_int
from ..errors import InputError, excerpt

RESIZE_MODES = ("auto", "stretch", "crop")


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
