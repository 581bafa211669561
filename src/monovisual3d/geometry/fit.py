"""Least-squares fit of a sphere, spheroid or ellipsoid to its associated boxes in several views.

The residual of each box edge is ``(predicted - observed) / sigma``, with the
predicted box the exact one of :func:`~monovisual3d.geometry.ellipsoid.ellipsoid_bbox`
and ``sigma = sqrt((1.118 * box_sigma * size)^2 + edge_sigma_px^2)`` (``size`` the
observed box width for x edges, height for y edges; 1.118 = sqrt(1.25) is the
per-edge std of the simulator's relative box noise). A robust loss on each edge
(one of scipy's, solved as :func:`scipy.optimize.least_squares` does; ``cauchy`` by default, after a first pass with
``soft_l1`` that finds the basin) keeps one loose or clipped-by-a-leaf edge from dragging the fit. Edges that lie on the image border
(truncated objects) or that a nearer object hides (``censored``) only say that the object reaches at least that far:
they count one-sided, where the prediction falls inside them (:mod:`.fit_edges`).

Models and parameters (``up`` the base frame's vertical; sizes are fitted as logarithms,
bounded by ``size_range``):

- ``sphere``: centre, radius;
- ``spheroid``: centre, horizontal semi-axis ``a = b``, vertical ``c`` (symmetry axis along
  ``up``); with ``free_orientation`` two tilts of the symmetry axis;
- ``ellipsoid``: centre, ``a, b`` (horizontal), ``c`` (along ``up``), yaw about ``up``; with
  ``free_orientation`` a full rotation instead of the yaw.

The solids of :mod:`.solids` (exact boxes of a cylinder's rims, of a cuboid's corners) take the parameters of the
ellipsoid with the same semi-axes: ``cylinder`` those of the ``spheroid`` (radius ``a``, half-height ``c``),
``cuboid`` those of the ``ellipsoid`` (half-sides ``a, b, c``, yaw).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError
from .ellipsoid import SHAPES, Ellipsoid, ellipsoid_bbox
from .fit_edges import edge_noise_px, hidden_edges, one_sided_edges, usable_edges
from .fit_starts import fit_starts
from .levenberg import LOSSES, Solution, levenberg_marquardt, named_loss
from .orientation import DEFAULT_UP, check_up, rotation_upright
from .solids import SOLIDS, cuboid_bbox, cylinder_bbox, union_boxes

if TYPE_CHECKING:
    from ..session import View

#: Default semi-axis range, metres (cherry tomatoes to cucumbers).
DEFAULT_SIZE_RANGE = (0.005, 0.25)
#: An observed edge within this many pixels of the image border counts as truncated.
DEFAULT_BORDER_PX = 1.0
#: Residual (in sigmas) given to an edge whose prediction is undefined (object behind the camera).
UNDEFINED_RESIDUAL = 1e4
#: Loss of the first pass of every fit (then ``loss`` from its solution).
FIRST_PASS_LOSS = "soft_l1"
#: Relative central-difference step of the Jacobian.
FD_STEP = 1e-6
#: Most residual evaluations of one fit, per parameter (scipy's default: 100). Past it a fit crawls along a kinked
#: valley (a cuboid's yaw against its sides): of 2,084 fits of two containers side by side, the 14 that ran past it
#: lowered their cost by under 1.5 % in up to 560 more evaluations, a seventh of all the fits' evaluations.
MAX_NFEV_PER_PARAMETER = 20


@dataclass(frozen=True)
class EllipsoidFit:
    """The result of :func:`fit_ellipsoid_boxes`.

    Attributes
    ----------
    ellipsoid : Ellipsoid, the fitted object (semi-axes ``a, b`` horizontal, ``c`` along ``up`` before any tilt)
    model : str, ``sphere``, ``spheroid``, ``ellipsoid``, ``cylinder`` or ``cuboid`` (``ellipsoid`` holds a solid's
        centre, semi-axes (radius or half-sides) and rotation)
    names : tuple of str, the fitted parameters
    centre_covariance : ndarray, shape (3, 3), m^2, base frame: Gauss-Newton covariance of the
        centre under the edge noise model (NaN when singular)
    residuals_px : ndarray, shape (E,), predicted minus observed edge of every used edge, pixels
    sigma_px : ndarray, shape (E,), the noise std of each used edge, pixels (``residuals_px / sigma_px``: normalised)
    used : ndarray, shape (K, 4), bool, the edges ``residuals_px`` holds, in its order (row by row)
    chi2 : float, sum of squared normalised residuals of the used edges, and of the hidden edges' one-sided ones
    cost : float, the robust cost minimised
    n_edges : int, edges used
    n_views : int, views with at least one used edge
    success : bool, the optimiser converged
    """

    ellipsoid: Ellipsoid
    model: str
    names: tuple[str, ...]
    centre_covariance: NDArray[np.float64]
    residuals_px: NDArray[np.float64]
    chi2: float
    cost: float
    n_edges: int
    n_views: int
    success: bool
    sigma_px: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    used: NDArray[np.bool_] = field(default_factory=lambda: np.zeros((0, 4), dtype=bool))

    @property
    def n_parameters(self) -> int:
        return len(self.names)

    @property
    def bic(self) -> float:
        """Bayesian information criterion ``chi2 + P ln(E)`` (Gaussian edges), to compare models on the same boxes."""
        return float(self.chi2 + self.n_parameters * math.log(max(self.n_edges, 1)))

    @property
    def rms_px(self) -> float:
        return float(np.sqrt(np.mean(self.residuals_px**2))) if len(self.residuals_px) else math.nan


def fit_parameters(model: str, *, free_orientation: bool = False) -> tuple[str, ...]:
    """Names of the parameters fitted for a model (sizes as natural logarithms of metres)."""
    if model not in SHAPES + SOLIDS:
        raise InputError(f"shape: got {model!r}, expected one of {list(SHAPES + SOLIDS)}")
    names = ["x", "y", "z"]
    if model == "sphere":
        return (*names, "log_r")
    if model in ("spheroid", "cylinder"):
        return (*names, "log_a", "log_c", *(("tilt_1", "tilt_2") if free_orientation else ()))
    return (*names, "log_a", "log_b", "log_c", *(("rx", "ry", "rz") if free_orientation else ("yaw",)))


def ellipsoid_from_parameters(
    theta: ArrayLike, model: str, *, up: ArrayLike = DEFAULT_UP, free_orientation: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Centres (..., 3), semi-axes (..., 3) and ``R_base_ellipsoid`` (..., 3, 3) from parameter vectors (..., P).

    The parameters are those of :func:`fit_parameters` (sizes as natural logarithms of metres).
    """
    u = check_up(up)
    return _decode(np.asarray(theta, dtype=float), model, u, rotation_upright(0.0, u), free_orientation)


def _decode(
    p: NDArray[np.float64], model: str, u: NDArray[np.float64], R0: NDArray[np.float64], free_orientation: bool
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    lead = p.shape[:-1]
    c = p[..., :3]
    if model == "sphere":
        s = np.repeat(np.exp(p[..., 3:4]), 3, axis=-1)
        return c, s, np.broadcast_to(np.eye(3), lead + (3, 3))
    if model in ("spheroid", "cylinder"):
        s = np.exp(p[..., [3, 3, 4]])
        if not free_orientation:
            return c, s, np.broadcast_to(R0, lead + (3, 3))
        rotvec = p[..., 5:6] * R0[:, 0] + p[..., 6:7] * R0[:, 1]
    else:
        s = np.exp(p[..., 3:6])
        rotvec = p[..., 6:9] if free_orientation else p[..., 6:7] * u
    return c, s, _rotation_from_rotvec(rotvec) @ R0


def _rotation_from_rotvec(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) (Rodrigues; exact near zero)."""
    theta = np.linalg.norm(rotvec, axis=-1)[..., None, None]
    x, y, z = rotvec[..., 0], rotvec[..., 1], rotvec[..., 2]
    zero = np.zeros_like(x)
    K = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)
    small = theta < 1e-6
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(small, 1.0 - theta**2 / 6.0, np.sin(theta) / theta)
        b = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(theta)) / theta**2)
    return np.eye(3) + a * K + b * (K @ K)


def fit_ellipsoid_boxes(
    camera: Camera,
    views: Sequence[View],
    associations: Mapping[int, int],
    *,
    shape: str = "spheroid",
    up: ArrayLike = DEFAULT_UP,
    free_orientation: bool = False,
    size_range: tuple[float, float] = DEFAULT_SIZE_RANGE,
    box_sigma: float = 0.05,
    edge_sigma_px: float = 1.0,
    loss: str = "cauchy",
    robust_scale: float = 2.0,
    border_px: float = DEFAULT_BORDER_PX,
    initial: Ellipsoid | None = None,
) -> EllipsoidFit:
    """Fit one object's shape to its boxes: the detections ``associations`` picks in ``views``.

    Parameters
    ----------
    camera : Camera
    views : sequence of View (``Session.views``): ``T_base_optical`` and ``detections``
    associations : mapping view index -> detection index, the object's boxes
        (``DetectedObject.associations``)
    shape, up, free_orientation, size_range, box_sigma, edge_sigma_px, loss, robust_scale, border_px, initial :
        see :func:`fit_ellipsoid_to_boxes`

    Returns
    -------
    EllipsoidFit

    Raises
    ------
    InputError
        An association names a view or detection that does not exist, or too few edges are usable.
    """
    poses, boxes = [], []
    for v, d in sorted(associations.items()):
        if not 0 <= int(v) < len(views):
            raise InputError(f"associations: view {v} does not exist (there are {len(views)} views)")
        dets = views[int(v)].detections
        if not 0 <= int(d) < len(dets):
            raise InputError(f"associations: view {v} has no detection {d} (it has {len(dets)})")
        poses.append(np.asarray(views[int(v)].T_base_optical, dtype=float))
        boxes.append(np.asarray(dets[int(d)].bbox_xyxy, dtype=float))
    return fit_ellipsoid_to_boxes(
        camera,
        np.array(poses).reshape(-1, 4, 4),
        np.array(boxes).reshape(-1, 4),
        shape=shape,
        up=up,
        free_orientation=free_orientation,
        size_range=size_range,
        box_sigma=box_sigma,
        edge_sigma_px=edge_sigma_px,
        loss=loss,
        robust_scale=robust_scale,
        border_px=border_px,
        initial=initial,
    )


def fit_ellipsoid_to_boxes(
    camera: Camera,
    T_base_optical: ArrayLike,
    boxes_xyxy: ArrayLike,
    *,
    shape: str = "spheroid",
    up: ArrayLike = DEFAULT_UP,
    free_orientation: bool = False,
    size_range: tuple[float, float] = DEFAULT_SIZE_RANGE,
    box_sigma: float = 0.05,
    edge_sigma_px: float = 1.0,
    loss: str = "cauchy",
    robust_scale: float = 2.0,
    border_px: float = DEFAULT_BORDER_PX,
    initial: Ellipsoid | None = None,
    censored: ArrayLike | None = None,
    hidden_to: ArrayLike | None = None,
) -> EllipsoidFit:
    """Fit a sphere, spheroid or ellipsoid to one object's boxes in K views.

    Parameters
    ----------
    camera : Camera
    T_base_optical : array_like, shape (K, 4, 4), the poses of the views
    boxes_xyxy : array_like, shape (K, 4), pixels, the object's box in each view
    shape : ``sphere``, ``spheroid`` or ``ellipsoid``
    up : array_like, shape (3,), base frame, the vertical of the upright models
    free_orientation : bool, fit the orientation instead of assuming upright (see the module docstring)
    size_range : (min, max), metres, bounds of every semi-axis
    box_sigma : float, relative box noise (per-edge std ``1.118 * box_sigma * size``)
    edge_sigma_px : float, pixels, absolute per-edge noise added in quadrature
    loss : str, robust loss, one of :data:`.levenberg.LOSSES` (scipy's; ``linear`` for plain least squares)
    robust_scale : float, sigmas at which the robust loss starts to discount an edge
    border_px : float, observed edges this close to the image border are truncated: they count one-sided (the
        object reaches at least that far, :func:`.fit_edges.one_sided_edges`) and not in ``n_edges``
    initial : Ellipsoid, optional starting point (default: centre triangulated from the box centres,
        sizes from the box sizes)
    censored : array_like, shape (K, 4), bool, optional: edges known to be cut (a nearer object hides the object
        there): they count one-sided, as border edges do
    hidden_to : array_like, shape (K, 4), pixels, optional: for a ``censored`` edge, how far the object can reach
        behind its occluder (the nearer box's far side; NaN: no limit); a prediction past it costs from it
        (:func:`.fit_edges.one_sided_edges`)

    Returns
    -------
    EllipsoidFit

    Examples
    --------
    >>> from monovisual3d.sim.viewpoints import paper_poses
    >>> cam = Camera.from_hfov(640, 480, 69.0)
    >>> true = Ellipsoid.spheroid([0.6, 0.02, 0.45], 0.022, 0.09)
    >>> fit = fit_ellipsoid_to_boxes(cam, paper_poses(), true.bbox(cam, paper_poses()), shape="spheroid")
    >>> np.round(fit.ellipsoid.centre_base, 6).tolist(), np.round(fit.ellipsoid.semi_axes, 6).tolist()
    ([0.6, 0.02, 0.45], [0.022, 0.022, 0.09])
    """
    if loss not in LOSSES:
        raise InputError(f"loss: got {loss!r}, expected one of {', '.join(LOSSES)}")
    names = fit_parameters(shape, free_orientation=free_orientation)
    u = check_up(up)
    lo, hi = _size_range(size_range)
    T, b, used, sigma = usable_edges(
        camera, T_base_optical, boxes_xyxy, names, shape, box_sigma, edge_sigma_px, border_px, censored
    )
    hidden = hidden_edges(camera, b, border_px, censored)
    counted = used | hidden
    sigma_all = edge_noise_px(b, box_sigma, edge_sigma_px)[counted]
    limits = _hidden_limits(hidden_to, b, hidden, counted)
    batch, jacobian = _edge_residuals(
        camera, T, counted, b[counted], sigma_all, shape, u, free_orientation, hidden[counted], limits
    )
    starts = fit_starts(camera, T, b, shape, u, free_orientation, lo, hi, initial)
    best = _least_squares_from(starts, batch, jacobian, names, lo, hi, loss, robust_scale)
    c, s, R = ellipsoid_from_parameters(best.x, shape, up=u, free_orientation=free_orientation)
    r = best.fun
    seen = ~hidden[counted]
    return EllipsoidFit(
        ellipsoid=Ellipsoid.from_rotation(c, s, R),
        model=shape,
        names=names,
        centre_covariance=_centre_covariance(best.jac),
        residuals_px=r[seen] * sigma,
        sigma_px=sigma,
        used=used,
        chi2=float(np.sum(r * r)),
        cost=float(best.cost),
        n_edges=int(used.sum()),
        n_views=int(np.sum(used.any(axis=1))),
        success=bool(best.success),
    )


def _edge_residuals(
    camera: Camera,
    T: NDArray[np.float64],
    counted: NDArray[np.bool_],
    observed: NDArray[np.float64],
    sigma: NDArray[np.float64],
    shape: str,
    u: NDArray[np.float64],
    free_orientation: bool,
    hidden: NDArray[np.bool_] | None = None,
    limits: NDArray[np.float64] | None = None,
) -> tuple[Callable[[NDArray[np.float64]], NDArray[np.float64]], Callable[[NDArray[np.float64]], NDArray[np.float64]]]:
    """The normalised residuals (N, E) of parameter vectors (N, P) and their central-difference Jacobian (E, P) at one;
    ``counted`` (K, 4): the edges whose residuals are returned, in row-major order; ``hidden`` (E,): those of them
    that count one-sided (:func:`one_sided_edges`), ``limits`` (E,), pixels: how far each may be hidden (NaN: no
    limit)."""
    R0 = rotation_upright(0.0, u)
    boxes_of = PinholeBoxes(camera, T) if camera.distortion_model == "none" else None
    edge_index = np.nonzero(counted)[1]

    def normalised(thetas: NDArray[np.float64]) -> NDArray[np.float64]:
        """Normalised residuals (N, E) of parameter vectors (N, P), all boxes in one batched call."""
        c, s, R = _decode(thetas, shape, u, R0, free_orientation)
        pred = _predicted_boxes(camera, T, boxes_of, shape, c, s, R)[:, counted]
        r = (pred - observed) / sigma
        if hidden is not None and hidden.any():
            r_limit = None if limits is None else (pred - limits) / sigma
            r = np.where(hidden, one_sided_edges(r, edge_index, r_limit), r)
        return np.where(np.isfinite(r), r, UNDEFINED_RESIDUAL)

    def jacobian(theta: NDArray[np.float64]) -> NDArray[np.float64]:
        h = FD_STEP * (1.0 + np.abs(theta))
        r = normalised(np.concatenate([theta + np.diag(h), theta - np.diag(h)]))
        return ((r[: len(theta)] - r[len(theta) :]) / (2 * h[:, None])).T

    return normalised, jacobian


def _hidden_limits(
    hidden_to: ArrayLike | None, b: NDArray[np.float64], hidden: NDArray[np.bool_], counted: NDArray[np.bool_]
) -> NDArray[np.float64] | None:
    """``hidden_to`` (K, 4), pixels, checked, at the ``counted`` edges (E,): NaN where an edge is seen or has no limit;
    None without any."""
    if hidden_to is None:
        return None
    limits = np.asarray(hidden_to, dtype=float)
    if limits.shape != b.shape:
        raise InputError(f"hidden_to: got shape {limits.shape}, expected {b.shape} (one limit per box edge)")
    return np.where(hidden, limits, np.nan)[counted]


def _predicted_boxes(
    camera: Camera,
    T: NDArray[np.float64],
    boxes_of: PinholeBoxes | None,
    shape: str,
    c: NDArray[np.float64],
    s: NDArray[np.float64],
    R: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Unclipped boxes (N, V, 4), pixels, of N objects (centres (N, 3), semi-axes (N, 3), rotations (N, 3, 3)) of the
    model ``shape`` in the V views ``T``; ``boxes_of``: the views' pinhole ellipsoid boxes (None with distortion)."""
    if shape == "cylinder" and boxes_of is not None:  # the rims: flat ellipsoids, semi-axes (r, r, 0)
        rim, flat = s[:, 2:3] * R[:, :, 2], s * np.array([1.0, 1.0, 0.0])
        return union_boxes(boxes_of(c - rim, flat, R), boxes_of(c + rim, flat, R))
    if shape == "cylinder":
        return cylinder_bbox(camera, T, c[:, None], s[:, None, 0], s[:, None, 2], R[:, None])
    if shape == "cuboid":
        return cuboid_bbox(camera, T, c[:, None], s[:, None], R[:, None])
    if boxes_of is not None:
        return boxes_of(c, s, R)
    return ellipsoid_bbox(camera, T, c[:, None], s[:, None], R[:, None], clip=False)


def _least_squares_from(
    starts: list[NDArray[np.float64]],
    batch: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    jacobian: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    names: tuple[str, ...],
    lo: float,
    hi: float,
    loss: str,
    robust_scale: float,
) -> Solution:
    """The lowest-cost solution over ``starts``, sizes bounded by ``[lo, hi]`` metres: :func:`.levenberg.levenberg_marquardt`
    (scipy's ``least_squares`` without bounds, step by step), and scipy's bounded solver where a size leaves that
    range."""
    log_lo, log_hi = math.log(lo), math.log(hi)
    lower = np.array([log_lo if n.startswith("log_") else -np.inf for n in names])
    upper = np.array([log_hi if n.startswith("log_") else np.inf for n in names])
    best = None
    for theta0 in starts:
        theta0 = np.clip(theta0, lower + 1e-9, upper - 1e-9)
        # a convex-ish first pass finds the basin; a redescending loss then discounts the bad edges
        for stage_loss in dict.fromkeys((FIRST_PASS_LOSS, loss)):
            # the unbounded solver is cheaper; a trial step far out overflows exp(log size): its residuals are
            # UNDEFINED_RESIDUAL, so the step costs more and is rejected; the overflow is expected, not an error
            with np.errstate(over="ignore", invalid="ignore"):
                res = levenberg_marquardt(
                    batch,
                    theta0,
                    "jac",
                    loss=named_loss(stage_loss, robust_scale),
                    jac=jacobian,
                    max_nfev=MAX_NFEV_PER_PARAMETER * len(theta0),
                )
            if np.any(res.x < lower) or np.any(res.x > upper):  # a size left size_range: solve again within it
                options = {
                    "jac": jacobian,
                    "loss": stage_loss,
                    "f_scale": robust_scale,
                    "x_scale": "jac",
                    "max_nfev": MAX_NFEV_PER_PARAMETER * len(theta0),
                }
                from scipy.optimize import least_squares  # on first use: 0.45 s to import, rarely needed

                b = least_squares(lambda th: batch(th[None])[0], theta0, bounds=(lower, upper), **options)
                res = Solution(b.x, b.fun, float(b.cost), b.jac, bool(b.success), int(b.nfev))
            theta0 = np.clip(res.x, lower + 1e-12, upper - 1e-12)
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    return best


def _centre_covariance(jac: NDArray[np.float64]) -> NDArray[np.float64]:
    """Gauss-Newton covariance (3, 3) of the centre, ``inv(J^T J)[:3, :3]``, NaN when singular."""
    with np.errstate(invalid="ignore", over="ignore"):
        JtJ = jac.T @ jac
        try:
            return np.linalg.inv(JtJ)[:3, :3]
        except np.linalg.LinAlgError:
            return np.full((3, 3), np.nan)


def fit_shape_by_bic(
    camera: Camera,
    T_base_optical: ArrayLike,
    boxes_xyxy: ArrayLike,
    shapes: Sequence[str] = SHAPES,
    every_model: bool = True,
    **options: Any,
) -> tuple[EllipsoidFit, dict[str, EllipsoidFit]]:
    """Fit every model of ``shapes`` and keep the one with the lowest :attr:`EllipsoidFit.bic`.

    Models that cannot be fitted (too few usable edges) are skipped. With the simulator's
    paper scene (spheres, 3 views, with or without the paper's box noise) this keeps every
    sphere a sphere; upright cucumbers and peppers come out as spheroids.

    Parameters
    ----------
    camera, T_base_optical, boxes_xyxy : see :func:`fit_ellipsoid_to_boxes`
    shapes : the candidate models, e.g. ``("sphere", "spheroid")``, fitted in this order
    every_model : bool, default True; False: a model is not fitted when its BIC cannot reach the lowest so far, its
        penalty ``P ln(E)`` alone (``chi2 >= 0``) being higher (for an ellipsoid model, higher than the lowest of the
        ellipsoid models, which a solid must beat clearly: see ``bayes``'s shape stage). The same ``best``, with
        ``fits`` holding only the models fitted.
    **options : passed to :func:`fit_ellipsoid_to_boxes`

    Returns
    -------
    best : EllipsoidFit
    fits : dict model -> EllipsoidFit, every model fitted

    Raises
    ------
    InputError
        No model could be fitted (the message of the simplest model's failure).
    """
    fits: dict[str, EllipsoidFit] = {}
    first_error: InputError | None = None
    for shape in shapes:
        if not every_model and hopeless(shape, fits, options.get("free_orientation", False)):
            continue
        try:
            fits[shape] = fit_ellipsoid_to_boxes(camera, T_base_optical, boxes_xyxy, shape=shape, **options)
        except InputError as exc:
            if shape not in SHAPES + SOLIDS:
                raise
            first_error = first_error or exc
    if not fits:
        assert first_error is not None
        raise first_error
    return min(fits.values(), key=lambda f: f.bic), fits


def hopeless(shape: str, fits: dict[str, EllipsoidFit], free_orientation: bool = False) -> bool:
    """Whether a ``shape`` fit's BIC cannot fall below the lowest of ``fits`` (of its ellipsoid models, for an ellipsoid
    model), its penalty ``P ln(E)`` alone exceeding it: all the fits use the same ``E`` edges."""
    rivals = [f for m, f in fits.items() if shape in SOLIDS or m not in SOLIDS]
    if not rivals:
        return False
    penalty = len(fit_parameters(shape, free_orientation=free_orientation)) * math.log(max(rivals[0].n_edges, 1))
    return penalty > min(f.bic for f in rivals)


class PinholeBoxes:
    """Unclipped boxes of N ellipsoids in V fixed undistorted views: the fit's hot path.

    The same closed form as :func:`~monovisual3d.geometry.ellipsoid.ellipsoid_bbox` (its
    reference, tested against it) with the views' rotations precomputed and only the five
    entries of the normalised dual conic that the box needs.

    Parameters
    ----------
    camera : Camera, without distortion
    T_base_optical : array_like, shape (V, 4, 4)
    """

    def __init__(self, camera: Camera, T_base_optical: ArrayLike) -> None:
        T = np.asarray(T_base_optical, dtype=float).reshape(-1, 4, 4)
        self.R_ob = np.ascontiguousarray(np.swapaxes(T[:, :3, :3], 1, 2))  # (V, 3, 3)
        self.t = T[:, :3, 3]
        self.f = np.array([camera.fx, camera.fy])
        self.pp = np.array([camera.cx, camera.cy])

    def __call__(
        self, centre_base: NDArray[np.float64], semi_axes: NDArray[np.float64], R: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Boxes (N, V, 4), pixels, NaN where not entirely in front, of centres (N, 3), semi-axes (N, 3), rotations (N, 3, 3)."""
        A = np.matmul(self.R_ob[None], (R * semi_axes[:, None, :])[:, None])  # (N, V, 3, 3): R_ob R diag(s)
        c = np.einsum("vij,nvj->nvi", self.R_ob, centre_base[:, None, :] - self.t[None])  # (N, V, 3)
        A2 = A[..., 2, :]
        n22 = np.einsum("nvk,nvk->nv", A2, A2) - c[..., 2] ** 2  # < 0 in front
        mxy = np.einsum("nvik,nvk->nvi", A[..., :2, :], A2) - c[..., :2] * c[..., 2:3]  # N02, N12
        mdiag = np.einsum("nvik,nvik->nvi", A[..., :2, :], A[..., :2, :]) - c[..., :2] ** 2  # N00, N11
        with np.errstate(invalid="ignore", divide="ignore"):
            k = np.where((n22 < 0) & (c[..., 2] > 0), -n22, np.nan)[..., None]
            x0 = -mxy / k
            h = np.sqrt(x0 * x0 + mdiag / k)
        lo = self.f * (x0 - h) + self.pp
        hi = self.f * (x0 + h) + self.pp
        return np.concatenate([lo, hi], axis=-1)


def _size_range(size_range: Any) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in size_range)
    except (TypeError, ValueError):
        raise InputError(f"size_range: got {size_range!r}, expected (min, max) semi-axis lengths in metres") from None
    if not (0 < lo < hi and math.isfinite(hi)):
        raise InputError(f"size_range: got ({lo:g}, {hi:g}), expected 0 < min < max (metres)")
    return lo, hi
