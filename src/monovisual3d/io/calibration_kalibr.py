"""Kalibr camchain YAML: ``cam0: {camera_model: pinhole, intrinsics: [fu, fv, pu, pv], distortion_model, distortion_coeffs, resolution}``."""

from __future__ import annotations

import re
from typing import Any

from ..camera import Camera
from ..checks import as_array, as_int, expect_object
from ..errors import InputError, excerpt
from .calibration_opencv import opencv_camera


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
    data = expect_object(data, "(top level)")
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
    cam = expect_object(cams[name], name)
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
    return opencv_camera(K, width, height, kalibr_models[dist], coeffs, name)
