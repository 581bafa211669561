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

import math
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

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
    >>> cam.project(np.array([0.0, 0.0, 1.0]))[0]
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
        for name in ("width", "height"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value <= 0:
                raise InputError(f"camera.{name}: expected a positive integer, got {value!r}")
        for name in ("fx", "fy", "cx", "cy"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value):
                raise InputError(f"camera.{name}: expected a finite number, got {value!r}")
        if self.fx <= 0 or self.fy <= 0:
            raise InputError(f"camera.fx/fy: expected positive focal lengths, got {self.fx}, {self.fy}")
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
        if not (isinstance(hfov_deg, (int, float)) and 0.0 < hfov_deg < 180.0):
            raise InputError(f"camera.hfov_deg: expected a number in (0, 180), got {hfov_deg!r}")
        if not isinstance(width, (int, np.integer)) or width <= 0:
            raise InputError(f"camera.width: expected a positive integer, got {width!r}")
        f = 0.5 * width / math.tan(0.5 * math.radians(hfov_deg))
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
        """Camera from the session file's ``camera`` object (see the README)."""
        from .session import camera_from_dict

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
        xy = self.distort(xy)
        uv = np.empty_like(xy)
        uv[..., 0] = self.fx * xy[..., 0] + self.cx
        uv[..., 1] = self.fy * xy[..., 1] + self.cy
        return uv

    def rays(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Unit viewing rays, in the optical frame, through pixel coordinates.

        Parameters
        ----------
        uv : array_like, shape (..., 2), pixels

        Returns
        -------
        d_optical : ndarray, shape (..., 3), unit vectors with z > 0
        """
        uv = np.asarray(uv, dtype=float)
        xy = np.empty_like(uv)
        xy[..., 0] = (uv[..., 0] - self.cx) / self.fx
        xy[..., 1] = (uv[..., 1] - self.cy) / self.fy
        xy = self.undistort(xy)
        d = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def in_image(self, uv: NDArray[np.floating]) -> NDArray[np.bool_]:
        """True where ``uv`` (shape (..., 2)) lies inside ``[0, width] x [0, height]``."""
        u, v = uv[..., 0], uv[..., 1]
        return (u >= 0) & (u <= self.width) & (v >= 0) & (v <= self.height)


def distort_normalised(xy: NDArray[np.floating], model: str, coeffs: tuple[float, ...]) -> NDArray[np.floating]:
    """OpenCV distortion of normalised coordinates, shape (..., 2) -> (..., 2)."""
    if model == "none" or not coeffs:
        return xy
    x, y = xy[..., 0], xy[..., 1]
    r2 = x * x + y * y
    if model == "equidistant":
        k1, k2, k3, k4 = coeffs
        r = np.sqrt(r2)
        theta = np.arctan(r)
        t2 = theta * theta
        theta_d = theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(r > 1e-12, theta_d / r, 1.0)
        return xy * scale[..., None]
    if model == "plumb_bob":
        k1, k2, p1, p2 = coeffs[:4]
        k3 = coeffs[4] if len(coeffs) > 4 else 0.0
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    else:  # rational_polynomial
        k1, k2, p1, p2, k3, k4, k5, k6 = coeffs
        radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=-1)


def undistort_normalised(
    xy_d: NDArray[np.floating], model: str, coeffs: tuple[float, ...], iterations: int = 20
) -> NDArray[np.floating]:
    """Invert :func:`distort_normalised` (fixed-point iteration; Newton for equidistant)."""
    if model == "none" or not coeffs:
        return xy_d
    if model == "equidistant":
        k1, k2, k3, k4 = coeffs
        rd = np.linalg.norm(xy_d, axis=-1)
        theta = rd.copy()
        for _ in range(iterations):
            t2 = theta * theta
            f = theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - rd
            df = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
            theta = theta - f / df
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(rd > 1e-12, np.tan(theta) / rd, 1.0)
        return xy_d * scale[..., None]
    xy = xy_d.copy()
    for _ in range(iterations):
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        if model == "plumb_bob":
            k1, k2, p1, p2 = coeffs[:4]
            k3 = coeffs[4] if len(coeffs) > 4 else 0.0
            radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        else:
            k1, k2, p1, p2, k3, k4, k5, k6 = coeffs
            radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        xy = np.stack([(xy_d[..., 0] - dx) / radial, (xy_d[..., 1] - dy) / radial], axis=-1)
    return xy
