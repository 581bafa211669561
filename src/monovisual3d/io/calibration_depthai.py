"""Luxonis DepthAI ``readCalibration()`` JSON dumps: ``cameraData`` per socket (perspective or fisheye)."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..checks import as_array, as_int, expect_object, is_int
from ..errors import InputError, InputWarning, excerpt
from .calibration_opencv import OPENCV_COEFF_NAMES, opencv_camera

#: DepthAI camera sockets by name (CameraBoardSocket).
DEPTHAI_SOCKETS = {"cam_a": 0, "rgb": 0, "color": 0, "cam_b": 1, "left": 1, "cam_c": 2, "right": 2}
for _i, _c in enumerate("defgh", start=3):
    DEPTHAI_SOCKETS[f"cam_{_c}"] = _i


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
    data = expect_object(data, "(top level)")
    entries = data.get("cameraData")
    if not isinstance(entries, list) or not entries:
        raise InputError("cameraData: expected a non-empty list of [socket, calibration] pairs")
    sockets: dict[int, Any] = {}
    for i, entry in enumerate(entries):
        if not isinstance(entry, list) or len(entry) != 2:
            raise InputError(f"cameraData[{i}]: expected a [socket, calibration] pair")
        sockets[as_int(entry[0], f"cameraData[{i}][0]", minimum=0)] = entry[1]
    number = _socket_number(socket, sockets)
    if number not in sockets:
        raise InputError(f"cameraData: no camera on socket {number}, the file has sockets {sorted(sockets)}")
    where = f"cameraData[socket {number}]"
    cam = expect_object(sockets[number], where)
    for k in ("intrinsicMatrix", "width", "height"):
        if k not in cam:
            raise InputError(f"{where}.{k}: missing field")
    K = as_array(cam["intrinsicMatrix"], f"{where}.intrinsicMatrix", shape=(3, 3))
    if not np.any(K):
        raise InputError(f"{where}.intrinsicMatrix: all zeros: this socket is not calibrated")
    width = as_int(cam["width"], f"{where}.width", minimum=1)
    height = as_int(cam["height"], f"{where}.height", minimum=1)
    D = as_array(cam.get("distortionCoeff", []), f"{where}.distortionCoeff").ravel()
    model, n, D = _distortion(cam, where, D)
    return opencv_camera(K, width, height, model, D[:n], f"{where}.distortionCoeff")


def _socket_number(socket: str | int | None, sockets: dict[int, Any]) -> int:
    """The socket asked for (number or name; default CAM_A, or the only one) among those of the file."""
    if socket is None:
        return 0 if 0 in sockets or len(sockets) > 1 else next(iter(sockets))
    if is_int(socket):
        return socket
    if str(socket).strip().isdigit():
        return int(str(socket).strip())
    name = str(socket).strip().lower().replace("camerabordsocket.", "").replace("cameraboardsocket.", "")
    if name not in DEPTHAI_SOCKETS:
        raise InputError(
            f"--camera-name (camera_name): unknown DepthAI socket {excerpt(socket)}, "
            f"expected a number or one of {sorted(DEPTHAI_SOCKETS)}"
        )
    return DEPTHAI_SOCKETS[name]


def _distortion(cam: dict[str, Any], where: str, D: NDArray[np.float64]) -> tuple[str, int, NDArray[np.float64]]:
    """``(model, number of coefficients modelled, coefficients)`` of one socket; warns about ignored non-zero terms."""
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
        known = OPENCV_COEFF_NAMES if model != "equidistant" else ()
        names = [known[k] if k < len(known) else f"c{k}" for k in range(n, D.size)]  # beyond OpenCV's 14: by index
        warnings.warn(
            InputWarning(
                f"{where}.distortionCoeff: ignoring non-zero terms {', '.join(names[i] for i in np.flatnonzero(tail))} "
                f"(max |value| {np.max(np.abs(tail)):.3g}); only the first {n} are modelled"
            ),
            stacklevel=4,  # the caller of camera_from_depthai
        )
    return model, n, D
