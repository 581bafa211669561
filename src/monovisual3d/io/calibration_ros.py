"""ROS calibrations: the YAML of ``camera_calibration``, or a ``sensor_msgs/CameraInfo`` (ROS 1 ``K, D``, ROS 2 ``k, d``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..camera import Camera
from ..checks import as_array, as_int
from ..errors import InputError
from .calibration_opencv import camera_from_opencv_storage, opencv_camera
from .image_size import crop_camera


def camera_from_camera_info(info: Any) -> Camera:
    """Camera from ROS: a ``camera_calibration`` YAML dict or a ``sensor_msgs/CameraInfo`` message.

    Messages may be ROS 1 (``K``, ``D``) or ROS 2 (``k``, ``d``) objects or dicts.
    ``binning_x/y`` and ``roi`` are applied, so the camera describes the
    published image.

    Examples
    --------
    >>> cam = camera_from_camera_info({"width": 640, "height": 480, "distortion_model": "plumb_bob",
    ...     "D": [0.0] * 5, "K": [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]})
    >>> cam.size
    (640, 480)
    """
    if isinstance(info, dict) and "camera_matrix" in info:
        return camera_from_opencv_storage(info, distortion_model=info.get("distortion_model"))
    get = field_getter(info)
    width = as_int(get("width"), "width", minimum=1)
    height = as_int(get("height"), "height", minimum=1)
    K = get("K", "k")
    if K is None:
        raise InputError("K: missing field, expected the 3x3 camera matrix (9 numbers)")
    K = as_array(K, "K", shape=(3, 3))
    if not np.any(K):
        raise InputError("K: all zeros: the camera is not calibrated")
    D = get("D", "d")
    D = as_array([] if D is None else D, "D").ravel()
    model = get("distortion_model")
    model = str(model) if model else None
    if not model and D.size:
        raise InputError("distortion_model: empty, but D has coefficients")
    camera = opencv_camera(K, width, height, model or "none", D, "D")
    return _roi_and_binning(camera, get, width, height)


def field_getter(obj: Any) -> Any:
    """``get(*names)``: the first present field among names, from a dict or an object (None when absent)."""

    def get(*names: str) -> Any:
        for n in names:
            if isinstance(obj, dict):
                if n in obj:
                    return obj[n]
            elif hasattr(obj, n):
                return getattr(obj, n)
        return None

    return get


def _roi_and_binning(camera: Camera, get: Any, width: int, height: int) -> Camera:
    """The camera of the published image: the message's ``roi`` crop, then its ``binning_x/y``."""
    bx = as_int(get("binning_x") or 1, "binning_x", minimum=1)
    by = as_int(get("binning_y") or 1, "binning_y", minimum=1)
    roi = get("roi")
    ox = oy = 0
    rw, rh = width, height
    if roi is not None:
        rget = field_getter(roi)
        ox = as_int(rget("x_offset") or 0, "roi.x_offset", minimum=0)
        oy = as_int(rget("y_offset") or 0, "roi.y_offset", minimum=0)
        rw = as_int(rget("width") or 0, "roi.width", minimum=0) or width
        rh = as_int(rget("height") or 0, "roi.height", minimum=0) or height
        if ox + rw > width or oy + rh > height:
            raise InputError(f"roi: {rw}x{rh}+{ox}+{oy} exceeds the {width}x{height} image")
    if (ox, oy, rw, rh) != (0, 0, width, height):
        camera = crop_camera(camera, (ox, oy, ox + rw, oy + rh))
    if bx > 1 or by > 1:
        w, h = camera.width // bx, camera.height // by
        if w < 1 or h < 1:
            raise InputError(f"binning_x/y: {bx}x{by} binning of a {camera.width}x{camera.height} image leaves nothing")
        camera = Camera(
            w,
            h,
            camera.fx / bx,
            camera.fy / by,
            camera.cx / bx,
            camera.cy / by,
            camera.distortion_model,
            camera.distortion_coefficients,
        )
    return camera
