"""Pinhole camera with lens distortion.

Pixel convention
----------------
Image coordinates are ``(u, v)`` in pixels, ``u`` to the right and ``v`` down.
The top-left corner of the image is ``(0, 0)`` and pixel centres lie at
integer + 0.5, so a pixel's box spans ``[i, i + 1)``. Bounding boxes
``bbox_xyxy = (x1, y1, x2, y2)`` use the same continuous coordinates (a box
that covers pixel columns 10..19 has ``x1 = 10, x2 = 20``), which is what
detectors such as YOLO report.

OpenCV, ROS ``camera_info`` and Kalibr put pixel centres at integers, so their
principal point is 0.5 px smaller than ours; :meth:`Camera.from_opencv` adds
the 0.5 and :meth:`Camera.opencv_matrix` removes it.

Distortion models (OpenCV's formulas on normalised coordinates):

- ``none``
- ``plumb_bob`` (alias ``radtan``): k1, k2, p1, p2[, k3]
- ``rational_polynomial``: k1, k2, p1, p2, k3, k4, k5, k6
- ``equidistant`` (alias ``fisheye``): k1, k2, k3, k4 (OpenCV fisheye model)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import limits
from .checks import expect_object, finite_number, is_int, reject_unknown
from .errors import InputError, excerpt

DISTORTION_ALIASES = {
    "none": "none",
    "plumb_bob": "plumb_bob",
    "radtan": "plumb_bob",
    "rational_polynomial": "rational_polynomial",
    "equidistant": "equidistant",
    "fisheye": "equidistant",
}
#: Accepted numbers of coefficients per (canonical) model.
DISTORTION_SIZES = {
    "none": (0,),
    "plumb_bob": (4, 5),
    "rational_polynomial": (8,),
    "equidistant": (4,),
}

#: Integer id of each (canonical) distortion model in :class:`PackedCamera`: the one table every
#: compiled kernel uses (numba engines, the ``bayes`` kernels, torch).
DISTORTION_IDS = {"none": 0, "plumb_bob": 1, "rational_polynomial": 2, "equidistant": 3}


#: Grid points per image side where :meth:`Camera.distortion_gain` samples the distortion's stretch.
DISTORTION_GAIN_SAMPLES = 33


class PackedCamera(NamedTuple):
    """A :class:`Camera` as plain numbers for the compiled kernels (see :meth:`Camera.packed`).

    Attributes
    ----------
    intrinsics : ndarray, shape (4,), float64, ``fx, fy, cx, cy`` in pixels (this project's convention)
    distortion_id : int, model id from :data:`DISTORTION_IDS`
    distortion : ndarray, shape (8,), float64, the model's coefficients in OpenCV order, zero padded:
        ``k1 k2 p1 p2 k3 k4 k5 k6`` for plumb_bob (``k3..k6 = 0`` where absent) and rational_polynomial,
        ``k1 k2 k3 k4`` then zeros for equidistant, zeros for none. A plumb_bob camera therefore
        projects the same through the rational formula (denominator 1).
    width, height : int, image size in pixels
    """

    intrinsics: NDArray[np.float64]
    distortion_id: int
    distortion: NDArray[np.float64]
    width: int
    height: int


@dataclass(frozen=True)
class Camera:
    """Pinhole camera intrinsics in the project's pixel convention.

    Parameters
    ----------
    width, height : int
        Image size in pixels, ``(width, height)``.
    fx, fy : float
        Focal lengths in pixels.
    cx, cy : float
        Principal point in pixels (pixel centres at integer + 0.5).
    distortion_model : str
        One of ``none``, ``plumb_bob``, ``rational_polynomial``, ``equidistant``
        (aliases ``radtan`` and ``fisheye`` accepted).
    distortion_coefficients : tuple of float
        The model's coefficients in OpenCV order.

    Examples
    --------
    >>> cam = Camera.from_hfov(640, 480, 69.0)
    >>> round(cam.fx, 1)
    465.6
    >>> cam.project(np.array([0.0, 0.0, 1.0]))
    array([320., 240.])
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion_model: str = "none"
    distortion_coefficients: tuple[float, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        check_image_size(self.width, self.height)
        check_intrinsics(self.fx, self.fy, self.cx, self.cy)
        model = DISTORTION_ALIASES.get(str(self.distortion_model).lower())
        if model is None:
            raise InputError(
                f"camera.distortion.model: unknown model {excerpt(self.distortion_model)}, expected one of {sorted(DISTORTION_ALIASES)}"
            )
        coeffs = tuple(float(c) for c in self.distortion_coefficients)
        if not all(math.isfinite(c) for c in coeffs):
            raise InputError("camera.distortion.coefficients: contains NaN or infinity")
        if model != "none" and not any(coeffs):
            model, coeffs = "none", ()
        if len(coeffs) not in DISTORTION_SIZES[model]:
            raise InputError(
                f"camera.distortion.coefficients: model {model} takes {' or '.join(map(str, DISTORTION_SIZES[model]))} coefficients, got {len(coeffs)}"
            )
        object.__setattr__(self, "distortion_model", model)
        object.__setattr__(self, "distortion_coefficients", coeffs)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        for name in ("fx", "fy", "cx", "cy"):
            object.__setattr__(self, name, float(getattr(self, name)))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_hfov(cls, width: int, height: int, hfov_deg: float) -> Camera:
        """Ideal camera from the horizontal field of view (the paper's Eq. 6).

        ``f = 0.5 * width / tan(0.5 * hfov)``, square pixels, principal point at the image centre.
        """
        hfov = finite_number(hfov_deg, "camera.hfov_deg")
        if not 0.0 < hfov < 180.0:
            raise InputError(f"camera.hfov_deg: got {hfov}, expected a value in (0, 180) degrees")
        check_image_size(width, height)
        f = 0.5 * width / math.tan(0.5 * math.radians(hfov))
        return cls(width, height, f, f, 0.5 * width, 0.5 * height)

    @classmethod
    def from_opencv(
        cls,
        camera_matrix: ArrayLike,
        width: int,
        height: int,
        distortion_model: str = "plumb_bob",
        distortion_coefficients: ArrayLike = (),
    ) -> Camera:
        """Camera from an OpenCV/ROS/Kalibr calibration (pixel centres at integers).

        Adds 0.5 px to the principal point to move it to this project's convention.
        """
        K = np.asarray(camera_matrix, dtype=float).reshape(3, 3)
        coeffs = tuple(np.asarray(distortion_coefficients, dtype=float).ravel().tolist())
        return cls(int(width), int(height), K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5, distortion_model, coeffs)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Camera:
        """Camera from the session file's ``camera`` object (see the README and :func:`camera_from_dict`)."""
        return camera_from_dict(data)

    # ------------------------------------------------------------------ exporters
    @property
    def K(self) -> NDArray[np.float64]:
        """Intrinsic matrix, shape (3, 3), in this project's pixel convention."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def opencv_matrix(self) -> NDArray[np.float64]:
        """Intrinsic matrix in OpenCV's convention (pixel centres at integers)."""
        K = self.K
        K[0, 2] -= 0.5
        K[1, 2] -= 0.5
        return K

    @property
    def size(self) -> tuple[int, int]:
        """Image size ``(width, height)``."""
        return (self.width, self.height)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
        }
        if self.distortion_model != "none":
            out["distortion"] = {"model": self.distortion_model, "coefficients": list(self.distortion_coefficients)}
        return out

    def scaled(self, width: int, height: int) -> Camera:
        """The same camera for an image resized to ``(width, height)`` (e.g. detector input size).

        Focal lengths and principal point scale with the image; distortion
        (defined on normalised coordinates) is unchanged.
        """
        sx, sy = width / self.width, height / self.height
        return replace(
            self, width=int(width), height=int(height), fx=self.fx * sx, fy=self.fy * sy, cx=self.cx * sx, cy=self.cy * sy
        )

    def packed(self) -> PackedCamera:
        """The camera as plain arrays for the compiled kernels (one packing for every engine).

        Examples
        --------
        >>> cam = Camera(640, 480, 500.0, 500.0, 320.0, 240.0, "plumb_bob", (0.1, -0.05, 0.001, 0.002))
        >>> p = cam.packed()
        >>> p.distortion_id, p.distortion.tolist()
        (1, [0.1, -0.05, 0.001, 0.002, 0.0, 0.0, 0.0, 0.0])
        """
        dist = np.zeros(8)
        dist[: len(self.distortion_coefficients)] = self.distortion_coefficients
        return PackedCamera(
            intrinsics=np.array([self.fx, self.fy, self.cx, self.cy]),
            distortion_id=DISTORTION_IDS[self.distortion_model],
            distortion=dist,
            width=self.width,
            height=self.height,
        )

    # ------------------------------------------------------------------ geometry
    def distort(self, xy: NDArray[np.floating]) -> NDArray[np.floating]:
        """Apply lens distortion to normalised coordinates.

        Parameters
        ----------
        xy : ndarray, shape (..., 2), normalised image coordinates ``(x/z, y/z)``

        Returns
        -------
        xy_distorted : ndarray, shape (..., 2)
        """
        return distort_normalised(xy, self.distortion_model, self.distortion_coefficients)

    def undistort(self, xy_distorted: NDArray[np.floating], iterations: int = 20) -> NDArray[np.floating]:
        """Invert :meth:`distort` iteratively (as ``cv2.undistortPoints`` does)."""
        return undistort_normalised(xy_distorted, self.distortion_model, self.distortion_coefficients, iterations)

    def project(self, p_optical: ArrayLike) -> NDArray[np.float64]:
        """Project points given in the optical frame to pixels.

        Parameters
        ----------
        p_optical : array_like, shape (..., 3), metres, optical frame

        Returns
        -------
        uv : ndarray, shape (..., 2), pixels. Points with ``z <= 0`` (behind the
            camera) give NaN; test with :meth:`in_front` or ``np.isfinite``.
        """
        p = np.asarray(p_optical, dtype=float)
        z = p[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            xy = p[..., :2] / z[..., None]
        xy = np.where((z > 0)[..., None], xy, np.nan)
        return self.pixels_from_normalised(self.distort(xy))

    def rays(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Unit viewing rays, in the optical frame, through pixel coordinates.

        Parameters
        ----------
        uv : array_like, shape (..., 2), pixels

        Returns
        -------
        d_optical : ndarray, shape (..., 3), unit vectors with z > 0
        """
        xy = self.undistort(self.normalised_from_pixels(uv))
        d = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def undistort_pixels(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Where pixels ``uv`` (shape (..., 2)) of this camera's image lie in the undistorted (pinhole) image, pixels."""
        return self.pixels_from_normalised(self.undistort(self.normalised_from_pixels(uv)))

    def normalised_from_pixels(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Normalised (still distorted) coordinates ``((u - cx) / fx, (v - cy) / fy)`` of pixels, shape (..., 2)."""
        uv = np.asarray(uv, dtype=float)
        xy = np.empty_like(uv)
        xy[..., 0] = (uv[..., 0] - self.cx) / self.fx
        xy[..., 1] = (uv[..., 1] - self.cy) / self.fy
        return xy

    def pixels_from_normalised(self, xy: NDArray[np.floating]) -> NDArray[np.float64]:
        """Pixels ``(fx x + cx, fy y + cy)`` of normalised (distorted) coordinates, shape (..., 2): the inverse of
        :meth:`normalised_from_pixels`."""
        uv = np.empty_like(xy)
        uv[..., 0] = self.fx * xy[..., 0] + self.cx
        uv[..., 1] = self.fy * xy[..., 1] + self.cy
        return uv

    def distortion_gain(self) -> float:
        """The most the lens distortion stretches a small move anywhere in the image, at least 1 (1 without distortion).

        The largest singular value of the Jacobian of :meth:`distort` (finite differences) over a grid of
        :data:`DISTORTION_GAIN_SAMPLES` squared points of the image. A bound on a move in the pinhole image times this
        bounds the move in the distorted one. Computed once per camera.
        """
        if self.distortion_model == "none" or not self.distortion_coefficients:
            return 1.0
        return _distortion_gain(self)

    def in_image(self, uv: NDArray[np.floating]) -> NDArray[np.bool_]:
        """True where ``uv`` (shape (..., 2)) lies inside ``[0, width] x [0, height]``."""
        u, v = uv[..., 0], uv[..., 1]
        return (u >= 0) & (u <= self.width) & (v >= 0) & (v <= self.height)


@functools.lru_cache(maxsize=16)
def _distortion_gain(camera: Camera) -> float:
    """:meth:`Camera.distortion_gain` of a camera with distortion."""
    n = DISTORTION_GAIN_SAMPLES
    u, v = np.meshgrid(np.linspace(0, camera.width, n), np.linspace(0, camera.height, n))
    xy = camera.undistort(camera.normalised_from_pixels(np.stack([u, v], axis=-1).reshape(-1, 2)))
    step = 1e-6
    jac = np.stack([(camera.distort(xy + step * e) - camera.distort(xy)) / step for e in np.eye(2)], axis=-1)
    return float(max(1.0, np.nanmax(np.linalg.svd(jac, compute_uv=False)[:, 0])))


# ---------------------------------------------------------------------- checks
def check_image_size(width: Any, height: Any, where: str = "camera") -> None:
    """Refuse an image size that is not two positive integers within :mod:`~monovisual3d.limits` (the one size check).

    Parameters
    ----------
    width, height : int, pixels
    where : str, the path named in the message (``camera``, ``views[2].camera``)
    """
    for name, value in (("width", width), ("height", height)):
        if not is_int(value) or value <= 0:
            raise InputError(f"{where}.{name}: expected a positive integer (pixels), got {excerpt(value)}")
        if value > limits.MAX_IMAGE_SIDE:
            raise InputError(f"{where}.{name}: got {excerpt(value)}, more than the {limits.MAX_IMAGE_SIDE} pixels accepted")
    if int(width) * int(height) > limits.MAX_IMAGE_PIXELS:
        raise InputError(f"{where}: a {width}x{height} image, more than the {limits.MAX_IMAGE_PIXELS:,} pixels accepted")


def check_intrinsics(fx: Any, fy: Any, cx: Any, cy: Any, where: str = "camera") -> None:
    """Refuse intrinsics that are not finite numbers within :data:`~monovisual3d.limits.MAX_ABS_INTRINSIC_PX`
    pixels, or focal lengths that are not positive (the one focal check)."""
    values = {"fx": fx, "fy": fy, "cx": cx, "cy": cy}
    for name, value in values.items():
        finite_number(value, f"{where}.{name}", limits.MAX_ABS_INTRINSIC_PX, "pixels")
    for name in ("fx", "fy"):
        if values[name] <= 0:
            raise InputError(f"{where}.{name}: got {float(values[name])}, expected a positive focal length in pixels")


#: Most distortion coefficients a file may list (OpenCV's longest model has 14).
MAX_DISTORTION_COEFFICIENTS = 14


def camera_from_dict(data: Any, where: str = "camera") -> Camera:
    """Camera from ``{"width", "height", "fx", "fy", "cx", "cy" | "hfov_deg", "distortion"}``.

    Parameters
    ----------
    data : dict, the session file's ``camera`` object (see the README)
    where : str, the path named in error messages

    Raises
    ------
    InputError
        One line naming ``where`` and the field, e.g. ``camera.fx: got 0.0, expected a positive focal length in pixels``.
    """
    expect_object(data, where)
    reject_unknown(data, {"width", "height", "fx", "fy", "cx", "cy", "hfov_deg", "distortion"}, where)
    for name in ("width", "height"):
        if name not in data:
            raise InputError(f"{where}.{name}: missing field, expected a positive integer (pixels)")
    check_image_size(data["width"], data["height"], where)
    has_k = [k for k in ("fx", "fy", "cx", "cy") if k in data]
    if "hfov_deg" in data and has_k:
        raise InputError(f"{where}: give either hfov_deg or fx/fy/cx/cy, not both")
    missing = [k for k in ("fx", "fy", "cx", "cy") if k not in data]
    if "hfov_deg" not in data and missing:
        raise InputError(f"{where}.{missing[0]}: missing field, expected fx, fy, cx, cy (pixels) or hfov_deg")
    if "hfov_deg" in data:
        cam = _named(where, lambda: Camera.from_hfov(data["width"], data["height"], data["hfov_deg"]))
    else:
        cam = _named(where, lambda: Camera(data["width"], data["height"], data["fx"], data["fy"], data["cx"], data["cy"]))
    model, coeffs = _distortion_from_dict(data.get("distortion"), f"{where}.distortion")
    return _named(where, lambda: replace(cam, distortion_model=model, distortion_coefficients=coeffs))


def _named(where: str, build: Callable[[], Camera]) -> Camera:
    """``build()``, with the ``camera.`` path of its error message renamed to ``where``."""
    try:
        return build()
    except InputError as exc:
        msg = str(exc)
        if msg.startswith("camera.") and where != "camera":
            msg = where + msg[len("camera") :]
        raise InputError(msg) from None


def _distortion_from_dict(dist: Any, where: str) -> tuple[str, tuple[float, ...]]:
    """``(model, coefficients)`` from the optional ``camera.distortion`` object (``none`` when absent)."""
    if dist is None:
        return "none", ()
    expect_object(dist, where)
    reject_unknown(dist, {"model", "coefficients"}, where)
    model = dist.get("model", "plumb_bob")
    if model is not None and not isinstance(model, str):
        raise InputError(f"{where}.model: expected a model name (text), got {excerpt(model)}")
    raw = dist.get("coefficients")
    if isinstance(raw, np.ndarray) and raw.ndim == 1:
        raw = raw.tolist()
    if not isinstance(raw, list):
        raise InputError(f"{where}.coefficients: expected a list of numbers, got {excerpt(raw)}")
    if len(raw) > MAX_DISTORTION_COEFFICIENTS:
        raise InputError(f"{where}.coefficients: {len(raw)} numbers, expected at most {MAX_DISTORTION_COEFFICIENTS} (OpenCV)")
    coeffs = tuple(finite_number(c, f"{where}.coefficients[{i}]", limits.MAX_ABS_DISTORTION) for i, c in enumerate(raw))
    return str(model), coeffs


# ---------------------------------------------------------------------- distortion
#: Below this radius (normalised units) the equidistant model's ``theta_d / r`` is taken as its limit, 1.
_EQUIDISTANT_MIN_RADIUS = 1e-12


def _equidistant_theta_d(theta: NDArray[np.floating], coeffs: tuple[float, ...]) -> NDArray[np.floating]:
    """OpenCV fisheye: distorted angle ``theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)``."""
    k1, k2, k3, k4 = coeffs
    t2 = theta * theta
    return theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))


def _equidistant_dtheta_d(theta: NDArray[np.floating], coeffs: tuple[float, ...]) -> NDArray[np.floating]:
    """Derivative of :func:`_equidistant_theta_d` with respect to ``theta``."""
    k1, k2, k3, k4 = coeffs
    t2 = theta * theta
    return 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))


def _radial_tangential(
    x: NDArray[np.floating], y: NDArray[np.floating], model: str, coeffs: tuple[float, ...]
) -> tuple[NDArray[np.floating], NDArray[np.floating], NDArray[np.floating]]:
    """OpenCV's radial factor and tangential shift at undistorted ``(x, y)`` (plumb_bob, rational_polynomial).

    Returns ``(radial, dx, dy)`` with ``x_distorted = x * radial + dx`` and ``y_distorted = y * radial + dy``.
    A plumb_bob model is the rational one with ``k4 = k5 = k6 = 0``.
    """
    k = np.zeros(8)
    k[: len(coeffs)] = coeffs
    k1, k2, p1, p2, k3, k4, k5, k6 = k
    r2 = x * x + y * y
    radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return radial, dx, dy


def distort_normalised(xy: NDArray[np.floating], model: str, coeffs: tuple[float, ...]) -> NDArray[np.floating]:
    """OpenCV distortion of normalised coordinates, shape (..., 2) -> (..., 2)."""
    if model == "none" or not coeffs:
        return xy
    if model == "equidistant":
        r = np.sqrt(xy[..., 0] ** 2 + xy[..., 1] ** 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(r > _EQUIDISTANT_MIN_RADIUS, _equidistant_theta_d(np.arctan(r), coeffs) / r, 1.0)
        return xy * scale[..., None]
    x, y = xy[..., 0], xy[..., 1]
    radial, dx, dy = _radial_tangential(x, y, model, coeffs)
    return np.stack([x * radial + dx, y * radial + dy], axis=-1)


def undistort_normalised(
    xy_d: NDArray[np.floating], model: str, coeffs: tuple[float, ...], iterations: int = 20
) -> NDArray[np.floating]:
    """Invert :func:`distort_normalised` (fixed-point iteration; Newton for equidistant)."""
    if model == "none" or not coeffs:
        return xy_d
    if model == "equidistant":
        rd = np.linalg.norm(xy_d, axis=-1)
        theta = rd.copy()
        for _ in range(iterations):
            theta = theta - (_equidistant_theta_d(theta, coeffs) - rd) / _equidistant_dtheta_d(theta, coeffs)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(rd > _EQUIDISTANT_MIN_RADIUS, np.tan(theta) / rd, 1.0)
        return xy_d * scale[..., None]
    xy = xy_d.copy()
    for _ in range(iterations):
        radial, dx, dy = _radial_tangential(xy[..., 0], xy[..., 1], model, coeffs)
        xy = np.stack([(xy_d[..., 0] - dx) / radial, (xy_d[..., 1] - dy) / radial], axis=-1)
    return xy
