"""Camera calibration readers: Kalibr, ROS camera_info, OpenCV FileStorage, Luxonis DepthAI.

All readers return a :class:`~monovisual3d.camera.Camera` in this project's
pixel convention (pixel centres at integer + 0.5): the calibration tools below
all put pixel centres at integers, so 0.5 px is added to their principal point
(see :meth:`Camera.from_opencv`).

Formats (``format=`` names):

- ``kalibr``: Kalibr camchain YAML, ``cam0: {camera_model: pinhole, intrinsics: [fu, fv, pu, pv],
  distortion_model: radtan | equidistant | none, distortion_coeffs, resolution: [w, h]}``.
- ``ros``: the YAML written by ROS ``camera_calibration`` (``image_width, image_height,
  camera_matrix: {rows, cols, data}, distortion_model, distortion_coefficients``), or a
  ``sensor_msgs/CameraInfo`` message (ROS 1 ``K, D`` or ROS 2 ``k, d``) as an object or a dict.
- ``opencv``: OpenCV FileStorage YAML (``%YAML:1.0``, ``!!opencv-matrix``) or JSON with
  ``camera_matrix`` and ``distortion_coefficients``; read without OpenCV.
- ``depthai``: Luxonis DepthAI ``readCalibration()`` JSON dump (``cameraData`` per socket:
  ``intrinsicMatrix``, ``distortionCoeff`` (14: k1, k2, p1, p2, k3, k4, k5, k6, s1..s4, tx, ty),
  ``width``, ``height``, ``cameraType`` 0 perspective / 1 fisheye).
- ``monovisual3d``: this project's session ``camera`` object (or a whole session file).

One module per format reads it (``calibration_kalibr``, ``calibration_ros``, ``calibration_opencv``,
``calibration_depthai``); this one detects the format and dispatches; :mod:`.image_size` adapts a
camera to the image size the boxes refer to.

When the detections were made on a resized (or cropped) image, pass the size the
boxes refer to as ``image_size``; see :func:`camera_for_image_size`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from numpy.typing import ArrayLike

from ..camera import Camera, camera_from_dict
from ..checks import expect_object
from ..errors import InputError, excerpt
from ._parse import load_json, load_yaml, read_text
from .calibration_depthai import camera_from_depthai
from .calibration_kalibr import camera_from_kalibr
from .calibration_opencv import MATRIX_KEYS, camera_from_opencv_storage
from .calibration_ros import camera_from_camera_info
from .image_size import camera_for_image_size, crop_camera

CALIBRATION_FORMATS = ("kalibr", "ros", "opencv", "depthai", "monovisual3d")


# ---------------------------------------------------------------------- entry point
def read_calibration(
    source: str | Path | dict[str, Any] | Any,
    *,
    format: str | None = None,
    camera_name: str | int | None = None,
    image_size: tuple[int, int] | None = None,
    resize: str = "auto",
    crop_xyxy: ArrayLike | None = None,
    distortion_model: str | None = None,
) -> Camera:
    """Read a camera calibration from a file, a parsed dict or a CameraInfo message.

    One unit of thought: the public reader; its documented options make most of its length, the body only dispatches to the format's reader.

    Parameters
    ----------
    source : path, dict or CameraInfo-like object
    format : str or None
        One of :data:`CALIBRATION_FORMATS`; detected from the content when None.
    camera_name : str or int or None
        Kalibr: ``cam0``/``cam1``... or the camera's rostopic. DepthAI: socket
        number or name (``CAM_A``, ``rgb``, ``left``...). Needed only when the
        file holds several cameras (DepthAI defaults to CAM_A).
    image_size : (width, height) or None
        Size of the images the detections were made on, when it differs from
        the calibration's; see :func:`camera_for_image_size`.
    resize : {"auto", "stretch", "crop"}
    crop_xyxy : array_like, shape (4,), or None
        A region of the calibration image (pixels, ``(x1, y1, x2, y2)``) that
        the detector's images were cropped to before resizing.
    distortion_model : str or None
        Override for files that do not name their model (OpenCV FileStorage:
        4 coefficients are plumb_bob unless ``fisheye`` is given).

    Returns
    -------
    Camera

    Raises
    ------
    InputError
        One line naming the file and the field.

    Examples
    --------
    >>> cam = read_calibration({"image_width": 640, "image_height": 480,
    ...     "camera_matrix": {"rows": 3, "cols": 3, "data": [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]},
    ...     "distortion_model": "plumb_bob", "distortion_coefficients": {"rows": 1, "cols": 5, "data": [0, 0, 0, 0, 0]}})
    >>> cam.cx, cam.cy
    (320.0, 240.0)
    """
    where, data, format = _calibration_data(source, format)
    fmt = calibration_format(data, where) if format is None else format.lower()
    if fmt not in CALIBRATION_FORMATS:
        raise InputError(f"{where}: --camera-format (format): got {excerpt(format)}, expected one of {list(CALIBRATION_FORMATS)}")
    try:
        camera = _camera_in_format(fmt, data, camera_name, distortion_model, image_size)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    if crop_xyxy is not None:
        camera = crop_camera(camera, crop_xyxy)
    if image_size is not None:
        try:
            camera = camera_for_image_size(camera, image_size, resize)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    return camera


def _calibration_data(source: Any, format: str | None) -> tuple[str, Any, str | None]:
    """``(where, parsed data, format)``: a file is read, a dict taken as is, anything else is a CameraInfo message."""
    if isinstance(source, (str, Path)):
        where = str(source)
        data = _load_calibration_file(Path(source))
    elif isinstance(source, dict):
        where = "calibration"
        data = source
    else:
        where = type(source).__name__
        data = source
        if format is None:
            format = "ros"
    return where, data, format


def _load_calibration_file(path: Path) -> Any:
    text = read_text(path)
    if path.suffix.lower() == ".json" or text.lstrip()[:1] == "{":
        return load_json(text, str(path))
    return load_yaml(text, str(path))


def _camera_in_format(
    fmt: str, data: Any, camera_name: str | int | None, distortion_model: str | None, image_size: tuple[int, int] | None
) -> Camera:
    """The reader of calibration format ``fmt`` (one of :data:`CALIBRATION_FORMATS`) applied to ``data``."""
    if fmt == "kalibr":
        camera = camera_from_kalibr(data, camera_name)
    elif fmt == "ros":
        camera = camera_from_camera_info(data)
    elif fmt == "opencv":
        camera = camera_from_opencv_storage(data, distortion_model=distortion_model, image_size=image_size)
    elif fmt == "depthai":
        camera = camera_from_depthai(data, camera_name)
    else:
        camera = _camera_from_monovisual3d(data)
    return camera


def calibration_format(data: Any, where: str = "calibration") -> str:
    """Name of the calibration format of parsed content (see :data:`CALIBRATION_FORMATS`).

    Examples
    --------
    >>> calibration_format({"cam0": {"intrinsics": [1, 1, 0, 0], "resolution": [2, 2]}})
    'kalibr'
    """
    if not isinstance(data, dict):
        if _has_any_attr(data, ("K", "k")) and _has_any_attr(data, ("width",)):
            return "ros"
        raise InputError(f"{where}: expected a calibration mapping, got {type(data).__name__}")
    keys = set(data)
    if "cameraData" in keys:
        return "depthai"
    if isinstance(data.get("camera"), dict) and "views" in keys:
        return "monovisual3d"
    if any(isinstance(v, dict) and "intrinsics" in v for k, v in data.items() if re.fullmatch(r"cam\d+", str(k))):
        return "kalibr"
    if ("K" in keys or "k" in keys) and "width" in keys and "height" in keys:
        return "ros"
    if "camera_matrix" in keys and "distortion_model" in keys:
        return "ros"
    if any(k in keys for k in MATRIX_KEYS):
        return "opencv"
    if {"width", "height"} <= keys and ({"fx", "fy", "cx", "cy"} <= keys or "hfov_deg" in keys):
        return "monovisual3d"
    raise InputError(
        f"{where}: unrecognised calibration (top-level keys {excerpt(sorted(keys, key=excerpt)[:8], 80)}); "
        f"expected one of {list(CALIBRATION_FORMATS)}, or name the format with --camera-format (format=...)"
    )


# ---------------------------------------------------------------------- this project's format
def _camera_from_monovisual3d(data: Any) -> Camera:
    data = expect_object(data, "(top level)")
    if isinstance(data.get("camera"), dict):
        return camera_from_dict(data["camera"])
    return camera_from_dict(data)


def _has_any_attr(obj: Any, names: tuple[str, ...]) -> bool:
    return any(hasattr(obj, n) for n in names)


__all__ = ["CALIBRATION_FORMATS", "calibration_format", "read_calibration"]
