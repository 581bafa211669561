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

When the detections were made on a resized (or cropped) image, pass the size the
boxes refer to as ``image_size``; see :func:`camera_for_image_size`.
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera, camera_from_dict
from ..errors import InputError, InputWarning, excerpt
from ._parse import as_array, as_int, expect_mapping, load_json, load_yaml, read_text

CALIBRATION_FORMATS = ("kalibr", "ros", "opencv", "depthai", "monovisual3d")
RESIZE_MODES = ("auto", "stretch", "crop")

_MATRIX_KEYS = ("camera_matrix", "cameraMatrix", "K", "M", "intrinsic_matrix", "intrinsics_matrix")
_DIST_KEYS = ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D", "distortion_coeffs", "dist_coeff")
_OPENCV_COEFF_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "tx", "ty")
#: DepthAI camera sockets by name (CameraBoardSocket).
DEPTHAI_SOCKETS = {"cam_a": 0, "rgb": 0, "color": 0, "cam_b": 1, "left": 1, "cam_c": 2, "right": 2}
for _i, _c in enumerate("defgh", start=3):
    DEPTHAI_SOCKETS[f"cam_{_c}"] = _i


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
    if any(k in keys for k in _MATRIX_KEYS):
        return "opencv"
    if {"width", "height"} <= keys and ({"fx", "fy", "cx", "cy"} <= keys or "hfov_deg" in keys):
        return "monovisual3d"
    raise InputError(
        f"{where}: unrecognised calibration (top-level keys {excerpt(sorted(keys, key=excerpt)[:8], 80)}); "
        f"expected one of {list(CALIBRATION_FORMATS)}, or name the format with --camera-format (format=...)"
    )


# ---------------------------------------------------------------------- Kalibr
def camera_from_kalibr(data: Any, camera_name: str | int | None = None) -> Camera:
    """Camera from a Kalibr camchain (``camchain.yaml`` or ``camchain-imucam.yaml``).

    Parameters
    ----------
    data : dict, the parsed YAML
    camera_name : ``cam0``, ``cam1``... or the camera's ``rostopic``; optional with one camera

    Examples
    --------
    >>> cam = camera_from_kalibr({"cam0": {"camera_model": "pinhole", "intrinsics": [500, 500, 319.5, 239.5],
    ...     "distortion_model": "radtan", "distortion_coeffs": [0.1, -0.2, 0.001, 0.002], "resolution": [640, 480]}})
    >>> cam.distortion_model, cam.cx
    ('plumb_bob', 320.0)
    """
    data = expect_mapping(data, "(top level)")
    cams = {str(k): v for k, v in data.items() if re.fullmatch(r"cam\d+", str(k))}
    if not cams:
        raise InputError("no camera entries (cam0, cam1, ...) in the Kalibr camchain")
    if camera_name is None:
        if len(cams) > 1:
            raise InputError(
                f"the camchain holds {len(cams)} cameras {sorted(cams)}: choose one with --camera-name (camera_name)"
            )
        name = next(iter(cams))
    else:
        name = str(camera_name)
        if name not in cams:
            by_topic = [k for k, v in cams.items() if isinstance(v, dict) and v.get("rostopic") == name]
            if not by_topic:
                raise InputError(
                    f"--camera-name (camera_name): no camera {excerpt(name)} in the camchain, expected one of {sorted(cams)}"
                )
            name = by_topic[0]
    cam = expect_mapping(cams[name], name)
    model = str(cam.get("camera_model", "pinhole"))
    if model != "pinhole":
        raise InputError(f"{name}.camera_model: {excerpt(model)} is not supported, expected 'pinhole'")
    if "intrinsics" not in cam:
        raise InputError(f"{name}.intrinsics: missing field, expected [fu, fv, pu, pv]")
    fu, fv, pu, pv = as_array(cam["intrinsics"], f"{name}.intrinsics", size=4).tolist()
    if "resolution" not in cam:
        raise InputError(f"{name}.resolution: missing field, expected [width, height]")
    res = cam["resolution"]
    if not isinstance(res, list) or len(res) != 2:
        raise InputError(f"{name}.resolution: expected [width, height], got {excerpt(res)}")
    width = as_int(res[0], f"{name}.resolution[0]", minimum=1)
    height = as_int(res[1], f"{name}.resolution[1]", minimum=1)
    dist = str(cam.get("distortion_model", "none")).lower()
    coeffs = as_array(cam.get("distortion_coeffs", []), f"{name}.distortion_coeffs").ravel()
    kalibr_models = {"radtan": "plumb_bob", "equidistant": "equidistant", "none": "none"}
    if dist not in kalibr_models:
        raise InputError(f"{name}.distortion_model: {excerpt(dist)} is not supported, expected one of {sorted(kalibr_models)}")
    expected = {"radtan": 4, "equidistant": 4, "none": 0}[dist]
    if coeffs.size != expected:
        raise InputError(f"{name}.distortion_coeffs: {dist} takes {expected} coefficients, got {coeffs.size}")
    K = [[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]]
    return _opencv_camera(K, width, height, kalibr_models[dist], coeffs, name)


# ---------------------------------------------------------------------- ROS
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
    get = _getter(info)
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
    camera = _opencv_camera(K, width, height, model or "none", D, "D")
    bx = as_int(get("binning_x") or 1, "binning_x", minimum=1)
    by = as_int(get("binning_y") or 1, "binning_y", minimum=1)
    roi = get("roi")
    ox = oy = 0
    rw, rh = width, height
    if roi is not None:
        rget = _getter(roi)
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


# ---------------------------------------------------------------------- OpenCV
def camera_from_opencv_storage(
    data: Any, *, distortion_model: str | None = None, image_size: tuple[int, int] | None = None
) -> Camera:
    """Camera from an OpenCV FileStorage mapping (YAML or JSON) or the ROS calibration YAML.

    Parameters
    ----------
    data : dict with a camera matrix (``camera_matrix``, ``cameraMatrix``, ``K``) and
        optionally distortion coefficients and the image size (``image_width``/``image_height``)
    distortion_model : str or None
        The model of the coefficients; by default inferred from their number
        (4 or 5: plumb_bob, 8: rational_polynomial). Fisheye calibrations must say ``fisheye``.
    image_size : (width, height), used only when the file does not give the size

    Examples
    --------
    >>> cam = camera_from_opencv_storage({"camera_matrix": {"type_id": "opencv-matrix", "rows": 3, "cols": 3,
    ...     "dt": "d", "data": [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]}, "image_width": 640, "image_height": 480})
    >>> cam.fx
    500.0
    """
    data = expect_mapping(data, "(top level)")
    key = next((k for k in _MATRIX_KEYS if k in data), None)
    if key is None:
        raise InputError(f"camera_matrix: missing field, expected one of {list(_MATRIX_KEYS)}")
    K = _opencv_matrix(data[key], key, shape=(3, 3))
    dkey = next((k for k in _DIST_KEYS if k in data), None)
    D = _opencv_matrix(data[dkey], dkey).ravel() if dkey is not None else np.zeros(0)
    width, height = _image_size_of(data, image_size)
    model = distortion_model if distortion_model else data.get("distortion_model")
    return _opencv_camera(K, width, height, str(model) if model else None, D, dkey or "distortion_coefficients")


def _opencv_matrix(value: Any, where: str, shape: tuple[int, int] | None = None) -> NDArray[np.float64]:
    if isinstance(value, dict):
        if "data" not in value:
            raise InputError(f"{where}.data: missing field, expected the matrix entries")
        arr = as_array(value["data"], f"{where}.data").ravel()
        if "rows" in value and "cols" in value:
            rows = as_int(value["rows"], f"{where}.rows", minimum=0)
            cols = as_int(value["cols"], f"{where}.cols", minimum=0)
            if rows * cols != arr.size:
                raise InputError(f"{where}: rows x cols = {rows} x {cols} but data has {arr.size} entries")
            arr = arr.reshape(rows, cols)
    else:
        arr = as_array(value, where)
    if shape is not None:
        if arr.size != shape[0] * shape[1]:
            raise InputError(f"{where}: expected {shape[0]}x{shape[1]} entries, got {arr.size}")
        arr = arr.reshape(shape)
    return arr


def _image_size_of(data: dict[str, Any], fallback: tuple[int, int] | None) -> tuple[int, int]:
    for wk, hk in (("image_width", "image_height"), ("width", "height"), ("imageWidth", "imageHeight")):
        if wk in data and hk in data:
            return as_int(data[wk], wk, minimum=1), as_int(data[hk], hk, minimum=1)
    for k in ("image_size", "imageSize", "resolution"):
        if k in data:
            size = _opencv_matrix(data[k], k).ravel()
            if size.size != 2:
                raise InputError(f"{k}: expected [width, height], got {size.size} numbers")
            return as_int(size[0], f"{k}[0]", minimum=1), as_int(size[1], f"{k}[1]", minimum=1)
    if fallback is not None:
        return _check_size(fallback, "image_size")
    raise InputError(
        "image_width/image_height: missing; the calibration does not give its image size "
        "(pass it with --image-size WxH, image_size=(w, h))"
    )


# ---------------------------------------------------------------------- DepthAI
def camera_from_depthai(data: Any, socket: str | int | None = None) -> Camera:
    """Camera from a Luxonis DepthAI calibration dump (``CalibrationHandler.eepromToJsonFile``).

    Parameters
    ----------
    data : dict with ``cameraData``: a list of ``[socket, {...}]`` pairs
    socket : int or name (``CAM_A``/``rgb`` = 0, ``CAM_B``/``left`` = 1, ``CAM_C``/``right`` = 2); default CAM_A

    Notes
    -----
    DepthAI stores 14 coefficients in OpenCV order. The first 8 (rational
    polynomial) are used; non-zero thin-prism/tilt terms (s1..s4, tx, ty) are
    not modelled and give an InputWarning. ``cameraType`` 1 (fisheye) uses the
    first 4 as equidistant k1..k4.

    Examples
    --------
    >>> cam = camera_from_depthai({"cameraData": [[0, {"width": 640, "height": 480,
    ...     "intrinsicMatrix": [[500, 0, 319.5], [0, 500, 239.5], [0, 0, 1]], "distortionCoeff": [0.0] * 14}]]})
    >>> cam.size
    (640, 480)
    """
    data = expect_mapping(data, "(top level)")
    entries = data.get("cameraData")
    if not isinstance(entries, list) or not entries:
        raise InputError("cameraData: expected a non-empty list of [socket, calibration] pairs")
    sockets: dict[int, Any] = {}
    for i, entry in enumerate(entries):
        if not isinstance(entry, list) or len(entry) != 2:
            raise InputError(f"cameraData[{i}]: expected a [socket, calibration] pair")
        sockets[as_int(entry[0], f"cameraData[{i}][0]", minimum=0)] = entry[1]
    if socket is None:
        number = 0 if 0 in sockets or len(sockets) > 1 else next(iter(sockets))
    elif isinstance(socket, int) and not isinstance(socket, bool):
        number = socket
    elif str(socket).strip().isdigit():
        number = int(str(socket).strip())
    else:
        name = str(socket).strip().lower().replace("camerabordsocket.", "").replace("cameraboardsocket.", "")
        if name not in DEPTHAI_SOCKETS:
            raise InputError(
                f"--camera-name (camera_name): unknown DepthAI socket {excerpt(socket)}, "
                f"expected a number or one of {sorted(DEPTHAI_SOCKETS)}"
            )
        number = DEPTHAI_SOCKETS[name]
    if number not in sockets:
        raise InputError(f"cameraData: no camera on socket {number}, the file has sockets {sorted(sockets)}")
    where = f"cameraData[socket {number}]"
    cam = expect_mapping(sockets[number], where)
    for k in ("intrinsicMatrix", "width", "height"):
        if k not in cam:
            raise InputError(f"{where}.{k}: missing field")
    K = as_array(cam["intrinsicMatrix"], f"{where}.intrinsicMatrix", shape=(3, 3))
    if not np.any(K):
        raise InputError(f"{where}.intrinsicMatrix: all zeros: this socket is not calibrated")
    width = as_int(cam["width"], f"{where}.width", minimum=1)
    height = as_int(cam["height"], f"{where}.height", minimum=1)
    D = as_array(cam.get("distortionCoeff", []), f"{where}.distortionCoeff").ravel()
    camera_type = as_int(cam.get("cameraType", 0), f"{where}.cameraType")
    if camera_type == 1:
        model, n = "equidistant", 4
    elif camera_type == 0:
        model, n = "rational_polynomial", 8
    else:
        raise InputError(f"{where}.cameraType: {camera_type} is not supported, expected 0 (perspective) or 1 (fisheye)")
    if D.size < n:
        D = np.concatenate([D, np.zeros(n - D.size)])
    tail = D[n:]
    if np.any(tail != 0):
        names = _OPENCV_COEFF_NAMES[n : n + tail.size] if model != "equidistant" else [f"c{i}" for i in range(n, D.size)]
        warnings.warn(
            InputWarning(
                f"{where}.distortionCoeff: ignoring non-zero terms {', '.join(names[i] for i in np.flatnonzero(tail))} "
                f"(max |value| {np.max(np.abs(tail)):.3g}); only the first {n} are modelled"
            ),
            stacklevel=3,
        )
    return _opencv_camera(K, width, height, model, D[:n], f"{where}.distortionCoeff")


# ---------------------------------------------------------------------- this project's format
def _camera_from_monovisual3d(data: Any) -> Camera:
    data = expect_mapping(data, "(top level)")
    if isinstance(data.get("camera"), dict):
        return camera_from_dict(data["camera"])
    return camera_from_dict(data)


# ---------------------------------------------------------------------- image size
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
    w, h = _check_size(image_size, "--image-size (image_size)")
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


# ---------------------------------------------------------------------- helpers
def opencv_distortion(coefficients: ArrayLike, model: str | None, where: str = "distortion") -> tuple[str, tuple[float, ...]]:
    """Canonical ``(model, coefficients)`` from an OpenCV-ordered coefficient list.

    Trailing terms this project does not model (thin prism, tilt) must be zero.

    Examples
    --------
    >>> opencv_distortion([0.1, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], None)
    ('rational_polynomial', (0.1, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    >>> opencv_distortion([0.1, 0.01, 0.0, 0.0], "fisheye")[0]
    'equidistant'
    """
    from ..camera import DISTORTION_ALIASES

    c = np.asarray(coefficients, dtype=float).ravel()
    n = c.size
    if model is None or str(model).strip() == "":
        if n == 0:
            return "none", ()
        canon = {
            4: "plumb_bob",
            5: "plumb_bob",
            8: "rational_polynomial",
            12: "rational_polynomial",
            14: "rational_polynomial",
        }.get(n)
        if canon is None:
            raise InputError(f"{where}: {n} coefficients; expected 4, 5, 8, 12 or 14 (OpenCV) or name the model")
    else:
        canon = DISTORTION_ALIASES.get(str(model).strip().lower())
        if canon is None:
            raise InputError(f"{where}: unknown distortion model {excerpt(model)}, expected one of {sorted(DISTORTION_ALIASES)}")
    keep = {"none": 0, "plumb_bob": 5, "rational_polynomial": 8, "equidistant": 4}[canon]
    if canon == "plumb_bob" and n == 4:
        keep = 4
    if n < keep:
        if canon == "equidistant" or (canon == "plumb_bob" and n < 4):
            raise InputError(f"{where}: model {canon} takes {keep} coefficients, got {n}")
        c = np.concatenate([c, np.zeros(keep - n)])
    if np.any(c[keep:] != 0):
        extra = [
            f"{_OPENCV_COEFF_NAMES[i] if canon != 'equidistant' and i < 14 else f'c{i}'}"
            for i in range(keep, c.size)
            if c[i] != 0
        ]
        raise InputError(f"{where}: model {canon} takes {keep} coefficients; the extra non-zero terms {extra} are not supported")
    return canon, tuple(float(v) for v in c[:keep])


def _opencv_camera(K: ArrayLike, width: int, height: int, model: str | None, coeffs: ArrayLike, where: str) -> Camera:
    K = np.asarray(K, dtype=float)
    if K[0, 1] != 0 or K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        if abs(K[0, 1]) > 1e-9 * max(abs(K[0, 0]), 1.0):
            raise InputError(f"camera matrix: skew {K[0, 1]} is not supported, expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]")
        if K[2, 2] == 0 or not math.isfinite(K[2, 2]):
            raise InputError(f"camera matrix: K[2][2] is {K[2, 2]}, expected 1")
        if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0:
            raise InputError(f"camera matrix: {K.tolist()} is not of the form [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]")
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # non-finite results: rejected by Camera
            K = K / K[2, 2]
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"camera matrix: focal lengths {K[0, 0]}, {K[1, 1]}, expected positive values")
    model, c = opencv_distortion(coeffs, model, where)
    return Camera.from_opencv(K, width, height, model, c)


def _check_size(size: Any, where: str) -> tuple[int, int]:
    if isinstance(size, (str, bytes)) or not hasattr(size, "__len__") or len(size) != 2:
        raise InputError(f"{where}: expected (width, height), got {excerpt(size)}")
    return as_int(size[0], f"{where}[0]", minimum=1), as_int(size[1], f"{where}[1]", minimum=1)


def parse_image_size(text: str) -> tuple[int, int]:
    """``"640x480"`` -> ``(640, 480)`` (also ``640,480``)."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX,]\s*(\d+)\s*", text)
    if not m:
        raise InputError(f"--image-size: got {excerpt(text)}, expected WIDTHxHEIGHT such as 640x480")
    return _check_size((int(m.group(1)), int(m.group(2))), "--image-size")


def _getter(obj: Any) -> Any:
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


def _has_any_attr(obj: Any, names: tuple[str, ...]) -> bool:
    return any(hasattr(obj, n) for n in names)


__all__ = [
    "CALIBRATION_FORMATS",
    "DEPTHAI_SOCKETS",
    "RESIZE_MODES",
    "calibration_format",
    "camera_for_image_size",
    "camera_from_camera_info",
    "camera_from_depthai",
    "camera_from_kalibr",
    "camera_from_opencv_storage",
    "crop_camera",
    "opencv_distortion",
    "parse_image_size",
    "read_calibration",
]
