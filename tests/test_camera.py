"""Camera: projection reference values, round trips, constructors, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d import Camera, InputError

#: One camera per distortion model, with moderate (realistic) coefficients.
MODELS = {
    "none": ("none", ()),
    "plumb_bob4": ("plumb_bob", (-0.21, 0.05, 0.0012, -0.0018)),
    "plumb_bob5": ("plumb_bob", (-0.21, 0.05, 0.0012, -0.0018, 0.012)),
    "radtan_alias": ("radtan", (0.08, -0.02, -0.001, 0.002)),
    "rational_polynomial": ("rational_polynomial", (-0.2, 0.05, 0.001, -0.002, 0.01, 0.1, 0.01, 0.002)),
    "equidistant": ("equidistant", (0.1, -0.05, 0.01, -0.002)),
    "fisheye_alias": ("fisheye", (-0.02, 0.01, 0.0, 0.0)),
}


def make_camera(model: str) -> Camera:
    name, coeffs = MODELS[model]
    return Camera(640, 480, 500.0, 510.0, 321.3, 239.7, name, coeffs)


def points_in_view(rng: np.random.Generator, n: int = 200) -> np.ndarray:
    """Points in front of the camera within about +-38 degrees of the axis, optical frame, metres."""
    z = rng.uniform(0.3, 3.0, n)
    xy = rng.uniform(-0.8, 0.8, (n, 2)) * z[:, None]
    return np.column_stack([xy, z])


# ---------------------------------------------------------------------- reference values
def test_project_hand_computed_pinhole() -> None:
    cam = Camera(640, 480, 500.0, 400.0, 320.0, 240.0)
    uv = cam.project(np.array([[0.1, 0.2, 1.0], [0.0, 0.0, 2.0], [-0.5, 0.25, 0.5]]))
    assert_allclose(uv, [[370.0, 320.0], [320.0, 240.0], [-180.0, 440.0]], atol=1e-12)


def test_project_hand_computed_plumb_bob() -> None:
    k1, k2, p1, p2, k3 = -0.2, 0.04, 0.001, -0.002, 0.01
    cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0, "plumb_bob", (k1, k2, p1, p2, k3))
    x, y = 0.1, 0.2
    r2 = x * x + y * y  # 0.05
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    assert_allclose(cam.project([0.2, 0.4, 2.0]), [500 * xd + 320, 500 * yd + 240], atol=1e-9)


def test_project_hand_computed_equidistant() -> None:
    k = (0.1, -0.05, 0.01, -0.002)
    cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0, "equidistant", k)
    theta = math.atan(0.5)  # point (0.5, 0, 1): 26.6 degrees off axis
    theta_d = theta * (1 + k[0] * theta**2 + k[1] * theta**4 + k[2] * theta**6 + k[3] * theta**8)
    assert_allclose(cam.project([0.5, 0.0, 1.0]), [320 + 500 * theta_d, 240.0], atol=1e-9)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_project_matches_opencv(model: str, rng: np.random.Generator) -> None:
    """Same pixels as cv2.projectPoints, shifted by our half-pixel convention (centres at integer + 0.5)."""
    cv2 = pytest.importorskip("cv2")
    cam = make_camera(model)
    p = points_in_view(rng)
    coeffs = np.array(cam.distortion_coefficients, dtype=float)
    if cam.distortion_model == "equidistant":
        ref, _ = cv2.fisheye.projectPoints(p[:, None, :], np.zeros(3), np.zeros(3), cam.opencv_matrix(), coeffs)
    else:
        ref, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), cam.opencv_matrix(), coeffs)
    assert_allclose(cam.project(p) - 0.5, ref.reshape(-1, 2), atol=1e-6)


def test_principal_point_convention_half_pixel() -> None:
    """The optical axis hits the image centre, which lies between pixels for even sizes."""
    cam = Camera.from_hfov(640, 480, 69.0)
    assert_allclose(cam.project([0.0, 0.0, 1.0]), [320.0, 240.0])
    assert_allclose(cam.opencv_matrix()[:2, 2], [319.5, 239.5])


# ---------------------------------------------------------------------- round trips
@pytest.mark.parametrize("model", sorted(MODELS))
def test_rays_invert_project(model: str, rng: np.random.Generator) -> None:
    cam = make_camera(model)
    p = points_in_view(rng)
    d = cam.rays(cam.project(p))
    assert d.shape == p.shape
    assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
    assert_allclose(d, p / np.linalg.norm(p, axis=-1, keepdims=True), atol=1e-8)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_project_inverts_rays(model: str, rng: np.random.Generator) -> None:
    cam = make_camera(model)
    uv = rng.uniform([40.0, 30.0], [600.0, 450.0], (200, 2))
    d = cam.rays(uv)
    assert np.all(d[:, 2] > 0)
    assert_allclose(cam.project(d * rng.uniform(0.2, 5.0, (200, 1))), uv, atol=1e-6)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_undistort_inverts_distort(model: str, rng: np.random.Generator) -> None:
    cam = make_camera(model)
    xy = rng.uniform(-0.6, 0.6, (100, 2))
    assert_allclose(cam.undistort(cam.distort(xy)), xy, atol=1e-8)


def test_project_keeps_leading_batch_dimensions(rng: np.random.Generator) -> None:
    cam = make_camera("plumb_bob5")
    p = points_in_view(rng, 24).reshape(2, 3, 4, 3)
    uv = cam.project(p)
    assert uv.shape == (2, 3, 4, 2)
    assert_allclose(uv.reshape(-1, 2), cam.project(p.reshape(-1, 3)))
    assert cam.rays(uv).shape == (2, 3, 4, 3)


def test_project_behind_camera_is_nan() -> None:
    cam = make_camera("plumb_bob5")
    uv = cam.project([[0.1, 0.1, -1.0], [0.0, 0.0, 0.0], [0.1, 0.1, 1.0]])
    assert np.all(np.isnan(uv[:2]))
    assert np.all(np.isfinite(uv[2]))


def test_in_image() -> None:
    cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0)
    uv = np.array([[0.0, 0.0], [640.0, 480.0], [-0.1, 10.0], [10.0, 480.1], [np.nan, 5.0]])
    assert cam.in_image(uv).tolist() == [True, True, False, False, False]


# ---------------------------------------------------------------------- constructors
@pytest.mark.parametrize(("width", "hfov_deg", "f"), [(640, 90.0, 320.0), (640, 60.0, 320.0 * math.sqrt(3)), (1280, 69.0, None)])
def test_from_hfov_focal_formula(width: int, hfov_deg: float, f: float | None) -> None:
    cam = Camera.from_hfov(width, 480, hfov_deg)
    expected = 0.5 * width / math.tan(0.5 * math.radians(hfov_deg)) if f is None else f
    assert_allclose([cam.fx, cam.fy, cam.cx, cam.cy], [expected, expected, 0.5 * width, 240.0], rtol=1e-12)
    # the image edge is seen at exactly half the field of view
    d = cam.rays([width, 240.0])
    assert_allclose(math.degrees(math.atan2(d[0], d[2])), 0.5 * hfov_deg, atol=1e-9)


@pytest.mark.parametrize("hfov_deg", [0.0, 180.0, -5.0, float("nan"), "69"])
def test_from_hfov_rejects_bad_fov(hfov_deg: object) -> None:
    with pytest.raises(InputError, match=r"camera\.hfov_deg"):
        Camera.from_hfov(640, 480, hfov_deg)  # type: ignore[arg-type]


@pytest.mark.parametrize("model", sorted(MODELS))
def test_scaled_scales_pixels(model: str, rng: np.random.Generator) -> None:
    """A resized image sees the same point at proportionally scaled pixel coordinates."""
    cam = make_camera(model)
    small = cam.scaled(320, 256)
    assert small.size == (320, 256)
    assert small.distortion_coefficients == cam.distortion_coefficients
    p = points_in_view(rng)
    assert_allclose(small.project(p), cam.project(p) * [320 / 640, 256 / 480], atol=1e-9)


def test_from_opencv_round_trip() -> None:
    K = np.array([[500.0, 0.0, 319.5], [0.0, 510.0, 239.5], [0.0, 0.0, 1.0]])
    cam = Camera.from_opencv(K, 640, 480, "plumb_bob", [-0.2, 0.05, 0.001, -0.002, 0.01])
    assert (cam.cx, cam.cy) == (320.0, 240.0)
    assert_allclose(cam.opencv_matrix(), K)
    assert cam.distortion_model == "plumb_bob"
    assert_allclose(cam.K[:2, 2], [320.0, 240.0])


def test_aliases_are_canonicalised() -> None:
    assert make_camera("radtan_alias").distortion_model == "plumb_bob"
    assert make_camera("fisheye_alias").distortion_model == "equidistant"


def test_all_zero_coefficients_mean_no_distortion() -> None:
    cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0, "plumb_bob", (0.0, 0.0, 0.0, 0.0, 0.0))
    assert cam.distortion_model == "none"
    assert "distortion" not in cam.to_dict()


def test_to_dict_from_dict_round_trip() -> None:
    cam = make_camera("rational_polynomial")
    assert Camera.from_dict(cam.to_dict()) == cam


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"width": 0}, r"camera\.width: expected a positive integer"),
        ({"height": 480.0}, r"camera\.height: expected a positive integer"),
        ({"width": True}, r"camera\.width"),
        ({"fx": float("nan")}, r"camera\.fx: got nan, expected a finite number"),
        ({"cy": float("inf")}, r"camera\.cy: got inf, expected a finite number"),
        ({"fy": -1.0}, r"camera\.fy: got -1\.0, expected a positive focal length in pixels"),
        ({"distortion_model": "kannala"}, r"camera\.distortion\.model: unknown model 'kannala'"),
        ({"distortion_model": "plumb_bob", "distortion_coefficients": (0.1, 0.0, 0.0)}, r"takes 4 or 5 coefficients, got 3"),
        ({"distortion_model": "equidistant", "distortion_coefficients": (0.1,) * 5}, r"takes 4 coefficients, got 5"),
        ({"distortion_model": "plumb_bob", "distortion_coefficients": (0.1, math.nan, 0, 0)}, r"NaN or infinity"),
    ],
)
def test_camera_rejects_bad_input(kwargs: dict[str, object], match: str) -> None:
    args: dict[str, object] = {"width": 640, "height": 480, "fx": 500.0, "fy": 500.0, "cx": 320.0, "cy": 240.0}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        Camera(**args)  # type: ignore[arg-type]


# ---------------------------------------------------------------------- one home: pixels, sizes, camera objects
@pytest.mark.parametrize("model", sorted(MODELS))
def test_undistort_pixels_inverts_projection(model: str, rng: np.random.Generator) -> None:
    """A point's distorted pixel, undistorted, is its pinhole projection."""
    cam = make_camera(model)
    p = points_in_view(rng)
    pinhole = Camera(cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy)
    assert_allclose(cam.undistort_pixels(cam.project(p)), pinhole.project(p), atol=1e-6)


def test_normalised_and_pixels_round_trip(rng: np.random.Generator) -> None:
    cam = make_camera("plumb_bob5")
    uv = rng.uniform(0, 640, (50, 2))
    assert_allclose(cam.pixels_from_normalised(cam.normalised_from_pixels(uv)), uv, atol=1e-9)
    assert_allclose(cam.normalised_from_pixels([[cam.cx + cam.fx, cam.cy]]), [[1.0, 0.0]])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"width": 40000}, r"^camera\.width: got 40000, more than the 32768 pixels accepted"),
        ({"width": 20000, "height": 20000}, r"^camera: a 20000x20000 image, more than the 67,108,864 pixels accepted"),
        ({"fx": 2e7}, r"^camera\.fx: got 2e\+07, beyond the 1e\+07 pixels accepted"),
        ({"fy": 0.0}, r"^camera\.fy: got 0\.0, expected a positive focal length in pixels"),
    ],
)
def test_camera_size_and_focal_checks_match_the_session_loader(kwargs: dict[str, object], match: str) -> None:
    """One check for width, height and focal lengths: a Camera refuses what a session file may not hold."""
    from monovisual3d.camera import camera_from_dict

    args: dict[str, object] = {"width": 640, "height": 480, "fx": 500.0, "fy": 500.0, "cx": 320.0, "cy": 240.0}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        Camera(**args)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=match):
        camera_from_dict(args)


def test_camera_from_dict_names_its_path() -> None:
    from monovisual3d.camera import camera_from_dict

    with pytest.raises(InputError, match=r"^views\[2\]\.camera\.fx: got 0\.0, expected a positive focal length"):
        camera_from_dict({"width": 640, "height": 480, "fx": 0, "fy": 500, "cx": 320, "cy": 240}, "views[2].camera")
    cam = camera_from_dict({"width": 640, "height": 480, "hfov_deg": 69.0, "distortion": {"coefficients": [0.1, 0, 0, 0]}})
    assert (cam.fx, cam.cx, cam.cy) == (Camera.from_hfov(640, 480, 69.0).fx, 320.0, 240.0)
    assert (cam.distortion_model, cam.distortion_coefficients) == ("plumb_bob", (0.1, 0.0, 0.0, 0.0))


def test_distortion_gain_bounds_how_far_the_lens_stretches_a_move(rng: np.random.Generator) -> None:
    """1 without distortion; with it, a small move anywhere in the image is stretched at most by the gain (and the
    gain is nearly reached)."""
    from dataclasses import replace

    cam = Camera.from_hfov(1280, 720, 90.0)
    assert cam.distortion_gain() == 1.0
    for coefficients in [(0.15, 0.05, 0.0, 0.0, 0.0), (-0.25, 0.08, 0.001, -0.001, 0.0)]:
        lens = replace(cam, distortion_model="plumb_bob", distortion_coefficients=coefficients)
        gain = lens.distortion_gain()
        xy = lens.undistort(lens.normalised_from_pixels(rng.uniform([0, 0], [1280, 720], (2000, 2))))
        step = rng.normal(size=(2000, 2)) * 1e-5
        stretch = np.linalg.norm(lens.distort(xy + step) - lens.distort(xy), axis=1) / np.linalg.norm(step, axis=1)
        assert gain >= 1.0 and np.all(stretch <= gain * (1 + 1e-3))
        assert stretch.max() >= 0.9 * gain or gain == 1.0
