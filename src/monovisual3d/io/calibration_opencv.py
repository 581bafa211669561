"""OpenCV calibrations: FileStorage YAML (``%YAML:1.0``, ``!!opencv-matrix``) or JSON, read without OpenCV;
and the OpenCV camera matrix and coefficient list every other reader converts through.

OpenCV puts pixel centres at integers, so 0.5 px is added to the principal point (see :meth:`Camera.from_opencv`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import as_array, as_int, expect_object
from ..errors import InputError, excerpt
from .image_size import size_pair

#: Keys under which calibration files store the camera matrix.
MATRIX_KEYS = ("camera_matrix", "cameraMatrix", "K", "M", "intrinsic_matrix", "intrinsics_matrix")
#: Keys under which calibration files store the distortion coefficients.
DISTORTION_KEYS = ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D", "distortion_coeffs", "dist_coeff")
#: OpenCV's distortion coefficients, in its order (14 at most).
OPENCV_COEFF_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "tx", "ty")
#: Relative size (of fx) below which a camera matrix's skew counts as zero.
MAX_RELATIVE_SKEW = 1e-9


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
    data = expect_object(data, "(top level)")
    key = next((k for k in MATRIX_KEYS if k in data), None)
    if key is None:
        raise InputError(f"camera_matrix: missing field, expected one of {list(MATRIX_KEYS)}")
    K = _opencv_matrix(data[key], key, shape=(3, 3))
    dkey = next((k for k in DISTORTION_KEYS if k in data), None)
    D = _opencv_matrix(data[dkey], dkey).ravel() if dkey is not None else np.zeros(0)
    width, height = _image_size_of(data, image_size)
    model = distortion_model if distortion_model else data.get("distortion_model")
    return opencv_camera(K, width, height, str(model) if model else None, D, dkey or "distortion_coefficients")


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
        return size_pair(fallback, "image_size")
    raise InputError(
        "image_width/image_height: missing; the calibration does not give its image size "
        "(pass it with --image-size WxH, image_size=(w, h))"
    )


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
            f"{OPENCV_COEFF_NAMES[i] if canon != 'equidistant' and i < 14 else f'c{i}'}" for i in range(keep, c.size) if c[i] != 0
        ]
        raise InputError(f"{where}: model {canon} takes {keep} coefficients; the extra non-zero terms {extra} are not supported")
    return canon, tuple(float(v) for v in c[:keep])


def opencv_camera(K: ArrayLike, width: int, height: int, model: str | None, coeffs: ArrayLike, where: str) -> Camera:
    """Camera from an OpenCV camera matrix (3, 3), pixels (centres at integers), and its distortion coefficients."""
    K = np.asarray(K, dtype=float)
    if K[0, 1] != 0 or K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        if abs(K[0, 1]) > MAX_RELATIVE_SKEW * max(abs(K[0, 0]), 1.0):
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
