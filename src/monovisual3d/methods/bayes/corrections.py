"""Corrections: the found objects refitted as spheres, all at once, jointly with one model of what is wrong.

A mistake in the input that every view shares leaves a pattern in the boxes' residuals that no fruit can take up
alone. Each :class:`CorrectionModel` is one such pattern with a few parameters ``theta``:

- ``hand_eye``: one camera-frame rigid motion shared by every view (a wrong hand-eye calibration):
  ``p_optical_true = exp([w]x) @ p_optical_reported + t``, ``theta = (w (3) radians, t (3) metres)``;
- ``time_offset``: each view's pose moved along the camera's path by ``dt`` times its velocity (poses stamped late
  or early against the images): ``theta = (dt,)``, seconds (view positions where the views carry no stamps);
- ``image_geometry``: one scale and offset of the pixels common to every view (boxes from another resolution, a
  crop, a resize): ``u_box = cx + sx (u - cx) + ox``, ``v_box = cy + sy (v - cy) + oy``,
  ``theta = (log sx, log sy, ox, oy)`` (pixels);
- ``radial_distortion``: a residual lens pattern (distortion coefficients in a wrong order or sign): each predicted
  edge point moved by ``k1 r^2`` radially and the tangential ``p1, p2`` terms, ``theta = (k1, p1, p2)``.

:func:`fit_correction` refits the spheres (``(x, y, z, log r)`` each) with one model, by Levenberg-Marquardt
(:func:`~monovisual3d.geometry.levenberg.levenberg_marquardt`), from the spheres refitted without a correction, and
returns the drop of the robust chi-square and the estimate with its covariance. Residuals are the box edges' offsets
from the predicted sphere boxes over the sensor model's edge noise (:func:`.sensor.box_edge_sigma_px`, at the start's
predictions), divided by the noise scale the spheres alone leave (:func:`noise_scale`: a detector noisier than the
model, or fruit that are not quite spheres, must not read as a correction); edges on the image border count only
outward; the loss is the redescending one of :mod:`.refine` (a box a leaf cuts is an outlier, not a pattern). A weak
prior (:attr:`CorrectionModel.prior_sigma`) keeps what the views cannot see of a correction at zero: on an arc of
views about one axis a hand-eye rotation about that axis together with a sideways shift moves every camera as one
rigid body (the scene moves with it; the boxes do not change), and a time offset along a path of constant speed does
the same.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...geometry.levenberg import levenberg_marquardt
from ...geometry.sphere import predict_sphere_boxes
from .correction_boxes import Boxes
from .refine import MIN_START_RADIUS_M, SPHERE_X_SCALE, robust_loss
from .sensor import UNDEFINED_RESIDUAL, SensorModel, box_edge_sigma_px, inward_edge_offsets

#: Residual evaluations a fit may spend (Levenberg-Marquardt trial points; each Jacobian is one batched call more).
MAX_NFEV = 60
#: The noise scale of the spheres' own fit is never taken below this share of the sensor model's noise (a detector
#: better than the model by more than that is not believed: the fit's own residuals understate the noise).
MIN_NOISE_SCALE = 0.25
#: MAD to standard deviation of a normal distribution.
MAD_TO_SIGMA = 1.4826


def _angle_and_skew(rotvec: NDArray[np.floating]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The angles (..., 1, 1) and skew-symmetric cross-product matrices ``[w]x`` (..., 3, 3) of rotation vectors (..., 3)."""
    w = np.asarray(rotvec, dtype=float)
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return np.linalg.norm(w, axis=-1)[..., None, None], K


def rotation_matrices(rotvec: NDArray[np.floating]) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3), radians (Rodrigues; exact at 0).

    Examples
    --------
    >>> R = rotation_matrices(np.array([0.0, 0.0, np.pi / 2]))
    >>> np.allclose(R @ [1.0, 0, 0], [0, 1.0, 0])
    True
    """
    theta, K = _angle_and_skew(rotvec)
    with np.errstate(invalid="ignore", divide="ignore"):
        small = theta < 1e-8
        a = np.where(small, 1.0 - theta**2 / 6.0, np.sin(theta) / np.where(small, 1.0, theta))
        b = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta) ** 2)
    return np.eye(3) + a * K + b * (K @ K)


def se3_v_matrices(rotvec: NDArray[np.floating]) -> NDArray[np.float64]:
    """The matrices ``V`` (..., 3, 3) of the SE(3) exponential of rotation vectors (..., 3): ``exp`` of the twist
    ``(w, rho)`` is the rotation ``exp([w]x)`` with the translation ``V(w) rho`` (a screw motion, exact for any angle)."""
    theta, K = _angle_and_skew(rotvec)
    with np.errstate(invalid="ignore", divide="ignore"):
        small = theta < 1e-6
        t = np.where(small, 1.0, theta)
        b = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(t)) / t**2)
        c = np.where(small, 1.0 / 6.0 - theta**2 / 120.0, (t - np.sin(t)) / t**3)
    return np.eye(3) + b * K + c * (K @ K)


def rotvec_from_matrix(R: NDArray[np.floating]) -> NDArray[np.float64]:
    """Rotation vector (3,), radians, of a rotation matrix (3, 3)."""
    from scipy.spatial.transform import Rotation

    return np.asarray(Rotation.from_matrix(np.asarray(R, dtype=float)).as_rotvec())


#: Turns the optical points (B, P, 3) of the boxes into corrected ones, given the parameters (B, m).
PointCorrection = Callable[[Boxes, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]
#: Turns the predicted boxes (B, P, 4) into corrected ones, given the parameters (B, m).
BoxCorrection = Callable[[Boxes, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


@dataclass(frozen=True)
class CorrectionModel:
    """One model of what is wrong with the input (see the module docstring).

    Attributes
    ----------
    name : str
    parameters : tuple of str, the names of ``theta``
    x_scale : ndarray, shape (m,), a meaningful change of each parameter (the solver's scale)
    prior_sigma : ndarray, shape (m,), the weak prior's std of each parameter (what the views cannot see stays 0)
    points : PointCorrection or None, how it moves the points in the optical frames
    boxes : BoxCorrection or None, how it moves the predicted boxes
    """

    name: str
    parameters: tuple[str, ...]
    x_scale: NDArray[np.float64]
    prior_sigma: NDArray[np.float64]
    points: PointCorrection | None = None
    boxes: BoxCorrection | None = None

    @property
    def size(self) -> int:
        return len(self.parameters)


def _hand_eye_points(b: Boxes, p: NDArray[np.float64], theta: NDArray[np.float64]) -> NDArray[np.float64]:
    R = rotation_matrices(theta[:, :3])
    return np.einsum("bij,bpj->bpi", R, p) + theta[:, None, 3:6]


def view_velocities(T_optical_base: NDArray[np.float64], stamps: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each view's velocity along the camera's path, its own optical frame: shape (V, 6), ``(w, v)`` per second.

    ``(w, rho)`` is the twist per second of the screw motion ``p_optical(t + dt) = exp([w dt]x) p_optical(t) +
    V(w dt) rho dt`` (:func:`se3_v_matrices`) of a point fixed in the base frame, from the neighbouring views' poses and stamps: each step between two views gives the rate at its
    middle time, and the rate at a view is interpolated linearly between the steps around it (extrapolated at the two
    end views, so that a path that speeds up is followed there too). Zero for a single view.
    """
    V = len(T_optical_base)
    out = np.zeros((V, 6))
    if V < 2:
        return out
    steps, mids = [], []
    for k in range(V - 1):
        # T_{k+1} T_k^-1 maps view k's optical frame into view k+1's: the motion of a fixed point as seen from the camera
        D = T_optical_base[k + 1] @ np.linalg.inv(T_optical_base[k])
        dt = float(stamps[k + 1] - stamps[k])
        w = rotvec_from_matrix(D[:3, :3])
        steps.append(np.concatenate([w, np.linalg.solve(se3_v_matrices(w), D[:3, 3])]) / dt)
        mids.append(0.5 * float(stamps[k + 1] + stamps[k]))
    if V == 2:
        return np.repeat(np.array(steps), 2, axis=0)
    s, m = np.array(steps), np.array(mids)
    for k in range(V):
        j = int(np.clip(np.searchsorted(m, stamps[k]) - 1, 0, len(m) - 2))  # the two steps around (or nearest) view k
        a = (float(stamps[k]) - m[j]) / (m[j + 1] - m[j])
        out[k] = (1 - a) * s[j] + a * s[j + 1]
    return out


def _time_offset_points(b: Boxes, p: NDArray[np.float64], theta: NDArray[np.float64]) -> NDArray[np.float64]:
    vel = view_velocities(b.T_optical_base, b.stamps)[b.view]  # (P, 6), cached below
    return _moved(p, vel, -theta[:, :1])


def _moved(p: NDArray[np.float64], vel: NDArray[np.float64], dt: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points (B, P, 3) as seen ``dt`` (B, 1) seconds later from views moving at the twists ``vel`` (P, 6)."""
    phi = dt[:, :, None] * vel[None, :, :3]
    t = np.einsum("bpij,bpj->bpi", se3_v_matrices(phi), dt[:, :, None] * vel[None, :, 3:])
    return np.einsum("bpij,bpj->bpi", rotation_matrices(phi), p) + t


def _image_geometry_boxes(b: Boxes, pred: NDArray[np.float64], theta: NDArray[np.float64]) -> NDArray[np.float64]:
    cam = b.camera
    sx, sy = np.exp(theta[:, 0])[:, None], np.exp(theta[:, 1])[:, None]
    ox, oy = theta[:, 2][:, None], theta[:, 3][:, None]
    out = np.empty_like(pred)
    out[..., 0] = cam.cx + sx * (pred[..., 0] - cam.cx) + ox
    out[..., 2] = cam.cx + sx * (pred[..., 2] - cam.cx) + ox
    out[..., 1] = cam.cy + sy * (pred[..., 1] - cam.cy) + oy
    out[..., 3] = cam.cy + sy * (pred[..., 3] - cam.cy) + oy
    return out


def distortion_shift(
    camera: Camera, x: NDArray[np.float64], y: NDArray[np.float64], theta: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """How far the residual lens pattern ``theta = (k1, p1, p2)`` (B, 3) moves points at normalised ``x, y``
    (B, P): ``(du, dv)`` pixels (OpenCV's radial and tangential terms of first order)."""
    k1, p1, p2 = (theta[:, i : i + 1] for i in range(3))
    r2 = x * x + y * y
    dx = k1 * r2 * x + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    dy = k1 * r2 * y + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return camera.fx * dx, camera.fy * dy


def _distortion_boxes(b: Boxes, pred: NDArray[np.float64], theta: NDArray[np.float64]) -> NDArray[np.float64]:
    cam = b.camera
    xs = (pred[..., [0, 2]] - cam.cx) / cam.fx  # the vertical edges' x, (B, P, 2)
    ys = (pred[..., [1, 3]] - cam.cy) / cam.fy
    xc, yc = xs.mean(axis=-1), ys.mean(axis=-1)
    out = pred.copy()
    for k, col in enumerate((0, 2)):  # vertical edges at their midpoint (x_k, yc)
        du, _ = distortion_shift(cam, xs[..., k], yc, theta)
        out[..., col] += du
    for k, col in enumerate((1, 3)):  # horizontal edges at (xc, y_k)
        _, dv = distortion_shift(cam, xc, ys[..., k], theta)
        out[..., col] += dv
    return out


#: The hand-eye model's prior std: 5 degrees and 20 mm per axis, beyond the hand-eye errors of a calibrated robot (a
#: degree or two, a centimetre) yet tight enough that the rotation-translation trade the views cannot see (a turn of
#: the camera and a sideways shift that keep the scene's centre in place) stays near zero.
HAND_EYE_PRIOR = np.array([math.radians(5.0)] * 3 + [0.02] * 3)
#: The models, by name.
MODELS: dict[str, CorrectionModel] = {
    "hand_eye": CorrectionModel(
        "hand_eye",
        ("rx", "ry", "rz", "tx", "ty", "tz"),
        np.array([0.01] * 3 + [0.005] * 3),
        HAND_EYE_PRIOR,
        points=_hand_eye_points,
    ),
    "time_offset": CorrectionModel("time_offset", ("dt",), np.array([0.05]), np.array([10.0]), points=_time_offset_points),
    "image_geometry": CorrectionModel(
        "image_geometry",
        ("log_sx", "log_sy", "ox", "oy"),
        np.array([0.01, 0.01, 2.0, 2.0]),
        np.array([1.0, 1.0, 500.0, 500.0]),
        boxes=_image_geometry_boxes,
    ),
    "radial_distortion": CorrectionModel(
        "radial_distortion",
        ("k1", "p1", "p2"),
        np.array([0.01, 0.002, 0.002]),
        np.array([1.0, 0.1, 0.1]),
        boxes=_distortion_boxes,
    ),
}


@dataclass(frozen=True)
class Fit:
    """What :func:`fit_correction` returns.

    Attributes
    ----------
    model : str, the correction model's name (``none``: the spheres alone)
    theta : ndarray, shape (m,), the correction's estimate
    theta_cov : ndarray, shape (m, m), its covariance (from the Gauss-Newton Hessian, noise scale included)
    centres : ndarray, shape (N, 3), metres, base frame, the refitted centres
    radii : ndarray, shape (N,), metres
    chi2 : float, the robust chi-square at the solution (twice the cost, data terms only)
    n_residuals : int, edges that count
    noise_scale : float, the residuals' scale the chi-square was computed with
    success : bool
    """

    model: str
    theta: NDArray[np.float64]
    theta_cov: NDArray[np.float64]
    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    chi2: float
    n_residuals: int
    noise_scale: float
    success: bool


class _Residuals:
    """The batched residuals of the spheres with one correction model (see the module docstring)."""

    def __init__(self, b: Boxes, model: CorrectionModel | None, sigma: NDArray[np.float64], prior: bool = True) -> None:
        self.b, self.model, self.sigma = b, model, sigma
        self.m = 0 if model is None else model.size
        self.prior = prior and model is not None
        if model is not None and model.points is _time_offset_points:
            self._vel = view_velocities(b.T_optical_base, b.stamps)[b.view]

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predicted boxes (B, P, 4), pixels, of the parameter vectors ``X`` (B, 4 N + m)."""
        b, N = self.b, self.b.n_objects
        obj = X[:, : 4 * N].reshape(len(X), N, 4)
        theta = X[:, 4 * N :]
        p = b.p_optical(obj[:, :, :3])
        if self.model is not None and self.model.points is not None:
            if self.model.points is _time_offset_points:
                p = _moved(p, self._vel, -theta[:, :1])
            else:
                p = self.model.points(b, p, theta)
        r = np.exp(obj[:, :, 3])[:, b.obj]
        pred, _ = predict_sphere_boxes(b.camera, p.reshape(-1, 3), r.reshape(-1, 1))
        pred = pred.reshape(len(X), -1, 4)
        if self.model is not None and self.model.boxes is not None:
            pred = self.model.boxes(b, pred, theta)
        return pred

    def __call__(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        b, N = self.b, self.b.n_objects
        theta = X[:, 4 * N :]
        pred = self.predict(X)
        d = inward_edge_offsets(pred, b.xyxy[None])
        d = np.where(b.censored[None], np.minimum(d, 0.0), d)
        e = np.nan_to_num(d / self.sigma[None], nan=UNDEFINED_RESIDUAL).reshape(len(X), -1)
        if self.prior and self.model is not None:
            e = np.concatenate([e, theta / self.model.prior_sigma], axis=1)
        return e


def grouped_jacobian(
    res: Callable[[NDArray[np.float64]], NDArray[np.float64]], b: Boxes, x: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Forward-difference Jacobian (n, 4 N + m) of the batched residuals ``res`` at ``x``: a box's residuals depend on
    its own object's 4 parameters and the correction's, so the same parameter of every object is stepped at once
    (4 + m evaluations in one batch, whatever the number of objects; the steps of :func:`.levenberg.forward_jacobian`)."""
    from ...geometry.levenberg import FD_REL_STEP

    N = b.n_objects
    k = len(x)
    h = FD_REL_STEP * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
    h = (x + h) - x
    groups = 4 + (k - 4 * N)
    X = np.repeat(x[None], 1 + groups, axis=0)
    for g in range(4):
        X[1 + g, g : 4 * N : 4] += h[g : 4 * N : 4]
    for j in range(k - 4 * N):
        X[5 + j, 4 * N + j] += h[4 * N + j]
    F = res(X)
    f0 = F[0]
    J = np.zeros((len(f0), k))
    n_data = 4 * len(b.obj)
    rows = np.arange(n_data)
    row_obj = np.repeat(b.obj, 4)
    for g in range(4):
        col = 4 * row_obj + g
        J[rows, col] = (F[1 + g, :n_data] - f0[:n_data]) / h[col]
    for j in range(k - 4 * N):
        J[:, 4 * N + j] = (F[5 + j] - f0) / h[4 * N + j]
    return J


def _loss(model: SensorModel, n_data: int) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """The redescending loss of :mod:`.refine` on the data residuals, the plain square on the prior's."""
    rho = robust_loss(model.inward_floor)

    def loss(z: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty((3, len(z)))
        out[:, :n_data] = rho(z[:n_data])
        out[0, n_data:], out[1, n_data:], out[2, n_data:] = z[n_data:], 1.0, 0.0
        return out

    return loss


def start_sigma(b: Boxes) -> NDArray[np.float64]:
    """The sensor model's edge noise (P, 4), pixels, at the starting spheres' predicted boxes."""
    p = b.p_optical(b.centres[None])[0]
    pred, _ = predict_sphere_boxes(b.camera, p, b.radii[b.obj][:, None])
    sigma = box_edge_sigma_px(b.model, pred[:, 0])
    return np.where(np.isfinite(sigma) & (sigma > 0), sigma, b.model.sigma0_px)


def noise_scale(residuals: NDArray[np.float64], n_parameters: int = 0) -> float:
    """The scale of normalised residuals left by a fit of ``n_parameters`` (robust: the MAD, widened by
    ``sqrt(n / (n - p))`` for what the fit took up), at least :data:`MIN_NOISE_SCALE`; 1 with too few residuals."""
    r = residuals[np.isfinite(residuals) & (residuals != 0)]
    if len(r) < 8 or len(r) <= 2 * n_parameters:
        return 1.0
    mad = MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r))))
    return max(MIN_NOISE_SCALE, mad * math.sqrt(len(r) / (len(r) - n_parameters)))


def scaled_sigma(b: Boxes, start: Fit | None = None) -> NDArray[np.float64]:
    """The edge noise (P, 4), pixels: :func:`start_sigma` times the :func:`noise_scale` the spheres (of ``start``, else
    of ``b``) leave."""
    base = start_sigma(b)
    r = _Residuals(b, None, base)(_x0(b, start)[None])[0]
    return base * noise_scale(r, 4 * b.n_objects)


def fit_correction(
    b: Boxes,
    model: str | None,
    *,
    sigma: NDArray[np.float64] | None = None,
    start: Fit | None = None,
    theta0: NDArray[np.floating] | None = None,
    max_nfev: int = MAX_NFEV,
) -> Fit:
    """Refit the spheres of ``b`` jointly with the correction ``model`` (None: the spheres alone).

    Parameters
    ----------
    b : Boxes
    model : str, a key of :data:`MODELS`, or None
    sigma : ndarray, shape (P, 4), pixels, the edge noise (default :func:`start_sigma` times the noise scale the
        spheres alone leave)
    start : Fit, the spheres to start from (default those of ``b``)
    theta0 : ndarray, shape (m,), the correction to start from (default 0)
    max_nfev : int

    Returns
    -------
    Fit

    """
    cm = None if model is None else MODELS[model]
    if sigma is None:
        sigma = scaled_sigma(b)
    x0 = _x0(b, start)
    m = 0 if cm is None else cm.size
    if cm is not None:
        x0 = np.concatenate([x0, np.zeros(m) if theta0 is None else np.asarray(theta0, dtype=float)])
    res = _Residuals(b, cm, sigma)
    n_data = 4 * len(b.xyxy)
    scale = np.concatenate([np.tile(SPHERE_X_SCALE, b.n_objects)] + ([cm.x_scale] if cm is not None else []))
    sol = levenberg_marquardt(
        res, x0, scale, loss=_loss(b.model, n_data), max_nfev=max_nfev, jac=lambda x: grouped_jacobian(res, b, x)
    )
    data = sol.fun[:n_data]
    chi2 = float(np.sum(robust_loss(b.model.inward_floor)(data * data)[0]))
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac)
    except np.linalg.LinAlgError:
        cov = np.full((len(x0), len(x0)), np.nan)
    obj = sol.x[: 4 * b.n_objects].reshape(-1, 4)
    ref = start_sigma(b)
    return Fit(
        "none" if model is None else model,
        sol.x[4 * b.n_objects :].copy(),
        cov[4 * b.n_objects :, 4 * b.n_objects :].copy(),
        obj[:, :3].copy(),
        np.exp(obj[:, 3]),
        chi2,
        int(np.sum(np.isfinite(data))),
        float(np.median(sigma / ref)),
        bool(sol.success),
    )


def _x0(b: Boxes, start: Fit | None) -> NDArray[np.float64]:
    centres, radii = (b.centres, b.radii) if start is None else (start.centres, start.radii)
    return np.column_stack([centres, np.log(np.maximum(radii, MIN_START_RADIUS_M))]).ravel()


@dataclass(frozen=True)
class Comparison:
    """One correction model tested against the spheres alone: :func:`compare_corrections`.

    Attributes
    ----------
    model : str
    chi2_drop : float, the robust chi-square the correction removes (chi-square with ``dof`` degrees of freedom under
        the sensor model's noise, scaled)
    dof : int
    fit : Fit, the fit with the correction
    """

    model: str
    chi2_drop: float
    dof: int
    fit: Fit


def compare_corrections(b: Boxes, models: Sequence[str], *, max_nfev: int = MAX_NFEV) -> tuple[Fit, list[Comparison]]:
    """The spheres alone, then refitted with each model from them, with the same noise: (base fit, tests)."""
    base = fit_correction(b, None, sigma=start_sigma(b), max_nfev=max_nfev)
    sigma = scaled_sigma(b, base)  # the noise the spheres' own optimum leaves: the tests' chi-squares are in its units
    base = fit_correction(b, None, sigma=sigma, start=base, max_nfev=max_nfev)
    tests = []
    for name in models:
        fit = fit_correction(b, name, sigma=sigma, start=base, max_nfev=max_nfev)
        tests.append(Comparison(name, max(0.0, base.chi2 - fit.chi2), MODELS[name].size, fit))
    return base, tests


# ---------------------------------------------------------------------- reading the estimates
def hand_eye_summary(fit: Fit) -> dict[str, Any]:
    """A hand-eye fit as a report: ``rotation_deg``, ``axis`` (unit, optical frame), ``translation_mm`` (norm) and
    ``translation_optical_mm`` (3,), each with its 1-sigma from the covariance, and ``T_corrected_reported`` (4, 4):
    ``p_optical_true = T @ p_optical_reported``."""
    w, t = fit.theta[:3], fit.theta[3:6]
    cov = fit.theta_cov
    angle = float(np.linalg.norm(w))
    axis = w / angle if angle > 0 else np.array([0.0, 0.0, 1.0])
    sd_angle = float(np.sqrt(max(axis @ cov[:3, :3] @ axis, 0.0)))
    tn = float(np.linalg.norm(t))
    u = t / tn if tn > 0 else np.array([0.0, 0.0, 1.0])
    sd_t = float(np.sqrt(max(u @ cov[3:6, 3:6] @ u, 0.0)))
    T = np.eye(4)
    T[:3, :3] = rotation_matrices(w)
    T[:3, 3] = t
    return {
        "rotation_deg": math.degrees(angle),
        "rotation_std_deg": math.degrees(sd_angle),
        "axis_optical": [float(x) for x in axis],
        "rotvec_optical_rad": [float(x) for x in w],
        "std_rotvec_optical_rad": [float(x) for x in np.sqrt(np.maximum(np.diag(cov)[:3], 0.0))],
        "translation_mm": 1e3 * tn,
        "translation_std_mm": 1e3 * sd_t,
        "translation_optical_mm": [1e3 * float(x) for x in t],
        "std_translation_optical_mm": [1e3 * float(x) for x in np.sqrt(np.maximum(np.diag(cov)[3:6], 0.0))],
        "T_corrected_reported": T.tolist(),
    }


def predicted_boxes(b: Boxes, fit: Fit) -> NDArray[np.float64]:
    """The boxes (P, 4), pixels, that a fit predicts (its spheres through its correction)."""
    x = np.concatenate([_x0(b, fit), fit.theta])[None]
    cm = None if fit.model == "none" else MODELS[fit.model]
    res = _Residuals(b, cm, np.ones_like(b.xyxy), prior=False)
    return res.predict(x)[0]
