"""Calibration readers: real-format fixtures, projection against OpenCV, image-size scaling."""

from __future__ import annotations

import json
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import Camera
from monovisual3d.errors import InputError, InputWarning
from monovisual3d.io import (
    calibration_format,
    camera_for_image_size,
    camera_from_camera_info,
    camera_from_depthai,
    crop_camera,
    read_calibration,
)
from monovisual3d.io._parse import load_yaml
from monovisual3d.io.calibration_opencv import opencv_distortion
from monovisual3d.io.image_size import parse_image_size


def points_in_view(rng: np.random.Generator, n: int = 200, spread: float = 0.7) -> np.ndarray:
    """Points in front of the camera, shape (n, 3), optical frame, |x/z|, |y/z| < spread."""
    z = rng.uniform(0.3, 3.0, n)
    xy = rng.uniform(-spread, spread, (n, 2)) * z[:, None]
    return np.column_stack([xy, z])


def cv2_project(points: np.ndarray, K: np.ndarray, D: np.ndarray, fisheye: bool = False) -> np.ndarray:
    """OpenCV's projection, moved to this project's convention (+0.5 px)."""
    cv2 = pytest.importorskip("cv2")
    rvec = np.zeros(3)
    tvec = np.zeros(3)
    if fisheye:
        uv, _ = cv2.fisheye.projectPoints(points.reshape(-1, 1, 3), rvec, tvec, K, D)
    else:
        uv, _ = cv2.projectPoints(points, rvec, tvec, K, D)
    return uv.reshape(-1, 2) + 0.5


def filestorage(path, key_K: str, key_D: str) -> tuple[np.ndarray, np.ndarray]:
    """K and D read by OpenCV itself (the reference for our OpenCV-free reader)."""
    cv2 = pytest.importorskip("cv2")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        return fs.getNode(key_K).mat(), fs.getNode(key_D).mat().ravel()
    finally:
        fs.release()


# ---------------------------------------------------------------------- Kalibr
def test_kalibr_radtan_camera(fixtures):
    cam = read_calibration(fixtures / "kalibr_camchain.yaml", camera_name="cam0")
    assert cam.size == (752, 480)
    assert cam.distortion_model == "plumb_bob"
    assert_allclose([cam.fx, cam.fy], [458.6548807207614, 457.2966964634893])
    assert_allclose([cam.cx, cam.cy], [367.2158039615726 + 0.5, 248.37534060980727 + 0.5])
    assert len(cam.distortion_coefficients) == 4


def test_kalibr_equidistant_by_name_or_rostopic(fixtures):
    by_name = read_calibration(fixtures / "kalibr_camchain.yaml", camera_name="cam1")
    by_topic = read_calibration(fixtures / "kalibr_camchain.yaml", camera_name="/cam1/image_raw")
    assert by_name == by_topic
    assert by_name.distortion_model == "equidistant"
    assert_allclose(by_name.distortion_coefficients[0], 0.0034823894022493434)


def test_kalibr_needs_a_name_with_several_cameras(fixtures):
    with pytest.raises(InputError, match=r"kalibr_camchain.yaml: the camchain holds 2 cameras \['cam0', 'cam1'\]"):
        read_calibration(fixtures / "kalibr_camchain.yaml")
    with pytest.raises(InputError, match="no camera 'cam7'"):
        read_calibration(fixtures / "kalibr_camchain.yaml", camera_name="cam7")


def test_kalibr_rejects_unsupported_models():
    cam = {"camera_model": "omni", "intrinsics": [1, 500, 500, 320, 240], "resolution": [640, 480]}
    with pytest.raises(InputError, match=r"cam0.camera_model: 'omni' is not supported"):
        read_calibration({"cam0": cam})
    cam = {"camera_model": "pinhole", "intrinsics": [500, 500, 320, 240], "resolution": [640, 480], "distortion_model": "fov"}
    with pytest.raises(InputError, match="cam0.distortion_model: 'fov' is not supported"):
        read_calibration({"cam0": cam})
    cam["distortion_model"] = "radtan"
    cam["distortion_coeffs"] = [0.1, 0.2, 0.0]
    with pytest.raises(InputError, match="radtan takes 4 coefficients, got 3"):
        read_calibration({"cam0": cam})


# ---------------------------------------------------------------------- ROS
def test_ros_camera_info_yaml(fixtures):
    cam = read_calibration(fixtures / "ros_camera_info.yaml")
    assert cam == Camera(640, 480, 462.5, 463.0, 319.75, 242.25, "plumb_bob", (0.04, -0.08, 0.001, -0.0007, 0.02))


@pytest.mark.parametrize("ros2", [False, True])
def test_camera_info_message_matches_yaml(fixtures, ros2):
    K = [462.5, 0, 319.25, 0, 463, 241.75, 0, 0, 1]
    D = np.array([0.04, -0.08, 0.001, -0.0007, 0.02])
    fields = {"k": np.array(K), "d": D} if ros2 else {"K": np.array(K), "D": D}
    roi = SimpleNamespace(x_offset=0, y_offset=0, width=0, height=0, do_rectify=False)
    msg = SimpleNamespace(width=640, height=480, distortion_model="plumb_bob", binning_x=0, binning_y=0, roi=roi, **fields)
    assert read_calibration(msg) == read_calibration(fixtures / "ros_camera_info.yaml")


def test_camera_info_binning_and_roi_describe_the_published_image(rng):
    K = np.array([[600.0, 0, 639.5], [0, 601.0, 479.5], [0, 0, 1]])
    full = Camera.from_opencv(K, 1280, 960, "plumb_bob", [0.05, -0.02, 0.001, 0.0, 0.0])
    roi = {"x_offset": 100, "y_offset": 40, "width": 800, "height": 600}
    msg = {"width": 1280, "height": 960, "K": K.ravel().tolist(), "D": [0.05, -0.02, 0.001, 0.0, 0.0]}
    msg.update(distortion_model="plumb_bob", binning_x=2, binning_y=2, roi=roi)
    cam = camera_from_camera_info(msg)
    assert cam.size == (400, 300)
    p = points_in_view(rng, 50, 0.3)
    uv_full = full.project(p)
    expected = (uv_full - [100, 40]) / 2.0
    assert_allclose(cam.project(p), expected, atol=1e-9)


def test_camera_info_rejects_uncalibrated_and_bad_roi():
    msg = {"width": 640, "height": 480, "K": [0.0] * 9, "D": [], "distortion_model": ""}
    with pytest.raises(InputError, match="K: all zeros: the camera is not calibrated"):
        camera_from_camera_info(msg)
    msg = {"width": 640, "height": 480, "K": [500, 0, 320, 0, 500, 240, 0, 0, 1], "D": [], "distortion_model": ""}
    msg["roi"] = {"x_offset": 600, "y_offset": 0, "width": 100, "height": 100}
    with pytest.raises(InputError, match=r"roi: 100x100\+600\+0 exceeds the 640x480 image"):
        camera_from_camera_info(msg)


# ---------------------------------------------------------------------- OpenCV
def test_opencv_yaml_reads_without_opencv(fixtures, monkeypatch):
    monkeypatch.setitem(sys.modules, "cv2", None)  # any import of cv2 would now fail
    cam = read_calibration(fixtures / "opencv_calibration.yaml")
    assert cam.size == (1280, 720)
    assert cam.distortion_model == "plumb_bob"
    assert_allclose(cam.distortion_coefficients, [0.12, -0.245756835937500, 1e-3, -5e-4, 0.10625])
    assert_allclose([cam.fx, cam.cx], [918.63524169921875, 640.35791015625 + 0.5])


def test_opencv_yaml_tags_and_directive_parse():
    text = "%YAML:1.0\n---\nm: !!opencv-matrix\n   rows: 1\n   cols: 2\n   dt: d\n   data: [ 1e-05, 2. ]\n"
    data = load_yaml(text, "x.yaml")
    assert data["m"]["type_id"] == "opencv-matrix"
    assert data["m"]["data"] == [1e-05, 2.0]


@pytest.mark.parametrize(
    ("name", "key_K", "key_D", "model", "fisheye"),
    [
        ("ros_camera_info.yaml", None, None, "plumb_bob", False),
        ("opencv_calibration.yaml", "camera_matrix", "distortion_coefficients", "plumb_bob", False),
        ("opencv_rational.json", "camera_matrix", "distortion_coefficients", "rational_polynomial", False),
        ("opencv_fisheye.yaml", "K", "D", "equidistant", True),
        ("kalibr_camchain.yaml", None, None, "equidistant", True),
        ("depthai_oak1.json", None, None, "rational_polynomial", False),
    ],
)
def test_projection_matches_opencv(fixtures, rng, name, key_K, key_D, model, fisheye):
    path = fixtures / name
    cam = read_calibration(
        path,
        distortion_model="fisheye" if name == "opencv_fisheye.yaml" else None,
        camera_name="cam1" if "kalibr" in name else None,
    )
    assert cam.distortion_model == model
    if key_K is not None:  # reference K and D straight from OpenCV's own FileStorage parser
        K, D = filestorage(path, key_K, key_D)
    else:
        K, D = cam.opencv_matrix(), np.array(cam.distortion_coefficients)
    assert_allclose(K, cam.opencv_matrix(), rtol=0, atol=1e-12)
    p = points_in_view(rng, spread=0.6)
    assert_allclose(cam.project(p), cv2_project(p, K, D, fisheye), rtol=0, atol=1e-6)


def test_fisheye_needs_the_model_named(fixtures):
    """Four coefficients without a model name are plumb_bob (OpenCV's default model), as documented."""
    assert read_calibration(fixtures / "opencv_fisheye.yaml").distortion_model == "plumb_bob"


def test_opencv_distortion_reduction():
    assert opencv_distortion([0.1, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0, 0], None)[0] == "rational_polynomial"
    assert opencv_distortion([0.1, 0.01, 0.001, 0.002], "plumb_bob") == ("plumb_bob", (0.1, 0.01, 0.001, 0.002))
    with pytest.raises(InputError, match=r"extra non-zero terms \['s1'\] are not supported"):
        opencv_distortion([0.1, 0.01, 0, 0, 0, 0, 0, 0, 0.003, 0, 0, 0], None)
    with pytest.raises(InputError, match="model equidistant takes 4 coefficients, got 3"):
        opencv_distortion([0.1, 0.2, 0.3], "fisheye")
    with pytest.raises(InputError, match="7 coefficients; expected 4, 5, 8, 12 or 14"):
        opencv_distortion([0.1] * 7, None)


# ---------------------------------------------------------------------- DepthAI
def test_depthai_oak1(fixtures):
    cam = read_calibration(fixtures / "depthai_oak1.json")
    assert cam.size == (4056, 3040)
    assert cam.distortion_model == "rational_polynomial"
    assert_allclose(
        [cam.fx, cam.fy, cam.cx, cam.cy], [3080.4716796875, 3079.36669921875, 2021.5479736328125 + 0.5, 1526.0538330078125 + 0.5]
    )
    assert_allclose(cam.distortion_coefficients[4], -10.40488624572754)
    assert read_calibration(fixtures / "depthai_oak1.json", camera_name="CAM_A") == cam
    assert read_calibration(fixtures / "depthai_oak1.json", camera_name="rgb") == cam


def test_depthai_sockets_and_ignored_terms(fixtures):
    data = json.loads((fixtures / "depthai_oak1.json").read_text())
    with pytest.raises(InputError, match=r"no camera on socket 1, the file has sockets \[0\]"):
        camera_from_depthai(data, "left")
    data["cameraData"][0][1]["distortionCoeff"][8] = 0.002
    with pytest.warns(InputWarning, match=r"ignoring non-zero terms s1 \(max \|value\| 0.002\)"):
        camera_from_depthai(data)
    data["cameraData"][0][1]["distortionCoeff"] = data["cameraData"][0][1]["distortionCoeff"][:14] + [0.0] * 7 + [0.004]
    with pytest.warns(InputWarning, match=r"ignoring non-zero terms s1, c21 \(max \|value\| 0.004\)"):  # beyond OpenCV's 14
        camera_from_depthai(data)
    data["cameraData"][0][1]["cameraType"] = 1
    data["cameraData"][0][1]["distortionCoeff"] = [0.01, -0.02, 0.003, -0.001] + [0.0] * 10
    assert camera_from_depthai(data).distortion_model == "equidistant"


# ---------------------------------------------------------------------- detection of the format
@pytest.mark.parametrize(
    ("name", "fmt"),
    [
        ("kalibr_camchain.yaml", "kalibr"),
        ("ros_camera_info.yaml", "ros"),
        ("opencv_calibration.yaml", "opencv"),
        ("opencv_rational.json", "opencv"),
        ("opencv_fisheye.yaml", "opencv"),
        ("depthai_oak1.json", "depthai"),
    ],
)
def test_format_is_detected_from_content(fixtures, name, fmt):
    text = (fixtures / name).read_text()
    data = json.loads(text) if name.endswith(".json") else load_yaml(text, name)
    assert calibration_format(data) == fmt


def test_unrecognised_and_explicit_formats(fixtures):
    with pytest.raises(InputError, match=r"calibration: unrecognised calibration \(top-level keys \['foo'\]\)"):
        read_calibration({"foo": 1})
    with pytest.raises(InputError, match=r"ros_camera_info.yaml: --camera-format \(format\): got 'matlab', expected one of"):
        read_calibration(fixtures / "ros_camera_info.yaml", format="matlab")
    cam = read_calibration({"width": 640, "height": 480, "fx": 500, "fy": 500, "cx": 320, "cy": 240})
    assert cam.cx == 320.0  # this project's own convention: no shift


# ---------------------------------------------------------------------- image size
def test_stretch_scaling_maps_pixels_linearly(rng):
    cam = Camera.from_opencv([[3080.0, 0, 2021.5], [0, 3079.0, 1526.0], [0, 0, 1]], 4056, 3040, "plumb_bob", [0.1, -0.2, 0, 0, 0])
    small = camera_for_image_size(cam, (1352, 1013))  # the aspect ratio agrees within one pixel: auto = stretch
    p = points_in_view(rng, 50, 0.4)
    assert_allclose(small.project(p), cam.project(p) * [1352 / 4056, 1013 / 3040], atol=1e-9)


def test_crop_scaling_is_uniform_scale_then_centre_crop(rng):
    cam = Camera.from_opencv([[3080.0, 0, 2021.5], [0, 3079.0, 1526.0], [0, 0, 1]], 4056, 3040)
    with pytest.raises(InputError, match="differ in aspect ratio; say how the images were made"):
        camera_for_image_size(cam, (1920, 1080))
    out = camera_for_image_size(cam, (1920, 1080), "crop")
    s = 1920 / 4056
    p = points_in_view(rng, 50, 0.3)
    assert_allclose(out.project(p), cam.project(p) * s - [0.0, 0.5 * (3040 * s - 1080)], atol=1e-9)


def test_crop_camera_and_explicit_isp_crop(fixtures, rng):
    cam = read_calibration(fixtures / "depthai_oak1.json")
    # a 4K-style ISP crop (3840x2160 from the centre of 4056x3040) scaled by 1/2 to 1920x1080
    isp = read_calibration(fixtures / "depthai_oak1.json", crop_xyxy=(108, 440, 3948, 2600), image_size=(1920, 1080))
    p = points_in_view(rng, 50, 0.2)
    assert_allclose(isp.project(p), (cam.project(p) - [108, 440]) / 2, atol=1e-9)
    with pytest.raises(InputError, match=r"--crop \(crop_xyxy\): .* is not a region inside the 4056x3040 image"):
        crop_camera(cam, (0, 0, 5000, 100))


def test_parse_image_size():
    assert parse_image_size("640x480") == (640, 480)
    with pytest.raises(InputError, match="expected WIDTHxHEIGHT"):
        parse_image_size("640")
