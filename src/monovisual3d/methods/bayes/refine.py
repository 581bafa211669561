"""Continuous refinement of one sphere from its associated boxes (and masks).

Robust nonlinear least squares (:func:`monovisual3d.geometry.levenberg.levenberg_marquardt`, scipy's ``least_squares`` the reference) on the
normalised box-edge residuals of :mod:`.likelihood`, with a redescending loss
that matches the sensor model: ``rho(z) = -2 log((exp(-z/2) + eps) / (1 + eps))``
with ``eps = exp(-inward_floor)``. Near zero it is the ordinary square; an
edge more than ~3 sigma off (occluded, truncated) stops pulling the estimate.
With ``floors`` (:func:`one_sided_residuals`) the floor depends on the residual's sign: the shape stage's final
sphere refit lets an edge inside the prediction (occlusion only shrinks a box) stop pulling sooner than one outside.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...geometry.levenberg import levenberg_marquardt
from ...geometry.sphere import pinhole_sphere_boxes, predict_sphere_boxes
from ...geometry.spheroid import predict_spheroid_boxes
from ._residuals import box_residuals_fused
from .likelihood import edge_residuals
from .masks import mask_residuals, mask_residuals_rays
from .sensor import UNDEFINED_RESIDUAL, SensorModel, box_edge_sigma_px, censored_edges, inward_edge_offsets

#: Views a sphere needs for a one-sided refit (:func:`refine_sphere` with ``floors``: an edge inside the prediction a
#: possible cut; ``shapes.one_sided_refit``, ``quality.cut_spheres``): from two, its 8 edges barely determine its 4
#: parameters, and an edge cannot be told a cut from noise by the others; letting inward edges go there moves the depth
#: (why: docs/decisions/bayes-occlusion.md#min_views_one_sided).
MIN_VIEWS_ONE_SIDED = 3


@dataclass
class Observation:
    """One associated detection.

    Attributes
    ----------
    T_optical_base : ndarray, shape (4, 4), the view's pose (as reported)
    bbox_xyxy : ndarray, shape (4,), pixels
    contour_uv : ndarray, shape (M, 2), pixels, mask outline points, or None
    extra_sigma_px : float, pixels, extra edge noise added in quadrature (e.g. the
        camera-pose uncertainty projected into the image, see
        :func:`monovisual3d.methods.bayes.likelihood.pose_sigma_px`); 0 by default
    censored : ndarray of bool, shape (4,), or None: edges ``x1, y1, x2, y2`` known to be cut by a nearer
        object (occlusion); like an edge on the image border, such an edge only says that the object reaches
        at least that far, so only its outward residual counts. None: only the border's edges are censored
    hidden_to : ndarray, shape (4,), pixels, or None: how far each censored edge may be hidden (the far side of the
        nearer box that hides it; NaN: no limit), for the shape fits
        (:func:`~monovisual3d.geometry.fit.fit_ellipsoid_to_boxes`)
    """

    T_optical_base: NDArray[np.float64]
    bbox_xyxy: NDArray[np.float64]
    contour_uv: NDArray[np.float64] | None = None
    extra_sigma_px: float = 0.0
    censored: NDArray[np.bool_] | None = None
    hidden_to: NDArray[np.float64] | None = None


@dataclass
class Refined:
    """Refined sphere: centre (3,) metres base frame, radius metres, position covariance (3, 3) m^2, cost.

    ``semi_up`` (metres) is set for an upright spheroid (``radius`` is then its semi-axis across ``up``).
    """

    centre: NDArray[np.float64]
    radius: float
    covariance: NDArray[np.float64]
    radius_std: float
    cost: float
    success: bool
    semi_up: float | None = None


def robust_loss(floor: float) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """The redescending loss of the module docstring as a loss callable of :func:`scipy.optimize.least_squares`
    (and :func:`monovisual3d.geometry.levenberg.levenberg_marquardt`).

    ``rho(z)`` of the squared residual ``z``; returns shape (3, len(z)): rho, rho', rho''.
    """
    eps = float(np.exp(-floor))

    def rho(z: NDArray[np.float64]) -> NDArray[np.float64]:
        g = np.exp(-0.5 * z)
        out = np.empty((3, len(z)))
        out[0] = -2.0 * (np.log(g + eps) - np.log1p(eps))
        out[1] = g / (g + eps)
        out[2] = -0.5 * g * eps / (g + eps) ** 2
        return out

    return rho


def observation_residuals(
    camera: Camera,
    p_optical: NDArray[np.floating],
    radius: float,
    observation: Observation,
    model: SensorModel,
    use_masks: bool = True,
) -> NDArray[np.float64]:
    """Normalised residuals of one observation for a sphere at ``p_optical`` (3,), metres, optical frame.

    Shape (4,) for a box (edges x1, y1, x2, y2), (M,) for a mask's contour points.
    """
    if use_masks and observation.contour_uv is not None:
        return mask_residuals(camera, p_optical, radius, observation.contour_uv, model, observation.extra_sigma_px)
    pred, _ = predict_sphere_boxes(camera, p_optical[None, :], np.array([radius]))
    e = edge_residuals(pred[0, 0], observation.bbox_xyxy, model, camera.width, camera.height, observation.extra_sigma_px)
    if observation.censored is not None:
        e = np.where(observation.censored, np.minimum(e, 0.0), e)  # the edge noise is positive: censor e as d
    return np.nan_to_num(e, nan=UNDEFINED_RESIDUAL)


def residuals(
    params: NDArray[np.floating], camera: Camera, observations: Sequence[Observation], model: SensorModel, use_masks: bool = True
) -> NDArray[np.float64]:
    """Stacked normalised residuals for ``params = (x, y, z, log r)`` (base frame, metres), observation by observation.

    The readable reference of what :func:`refine_sphere` minimises (it uses a batched,
    compiled twin with the box residuals first, then the masks').
    """
    c = params[:3]
    r = float(np.exp(params[3]))
    out = [
        observation_residuals(camera, ob.T_optical_base[:3, :3] @ c + ob.T_optical_base[:3, 3], r, ob, model, use_masks)
        for ob in observations
    ]
    return np.concatenate(out) if out else np.zeros(0)


class _BoxResiduals:
    """Box-edge residuals of a fixed set of box observations for many spheres at once (stacked once)."""

    def __init__(
        self, camera: Camera, observations: Sequence[Observation], model: SensorModel, up: NDArray[np.floating] | None = None
    ) -> None:
        self.camera, self.model = camera, model
        T = np.stack([ob.T_optical_base[:3, :4] for ob in observations])
        self.R, self.t = T[:, :, :3], T[:, :, 3]
        #: the spheroids' symmetry axis in each observation's optical frame (M, 3); zeros without one
        self.up_optical = self.R @ np.asarray(up, dtype=float) if up is not None else np.zeros((len(T), 3))
        obs = np.stack([np.asarray(ob.bbox_xyxy, dtype=float) for ob in observations])
        self.obs = obs
        self.extra = np.array([float(np.asarray(ob.extra_sigma_px)) for ob in observations])
        self.extra2 = self.extra**2
        self.censored = censored_edges(obs, camera.width, camera.height, model.border_px)
        for m, ob in enumerate(observations):
            if ob.censored is not None:
                self.censored[m] |= np.asarray(ob.censored, dtype=bool)

    def batch(
        self, centres_base: NDArray[np.floating], radii: NDArray[np.floating], semi_up: NDArray[np.floating] | None = None
    ) -> NDArray[np.float64]:
        """Residuals for centres (P, 3), metres, base frame, and radii (P,), metres: shape (P, 4 M).

        ``semi_up`` (P,), metres: upright spheroids (the axis given at construction) instead of spheres.
        """
        return box_residuals_fused(
            self.camera,
            self.R,
            self.t,
            self.obs,
            self.censored,
            self.extra2,
            centres_base,
            radii,
            self.model,
            semi_up,
            self.up_optical,
        )

    def batch_numpy(
        self, centres_base: NDArray[np.floating], radii: NDArray[np.floating], semi_up: NDArray[np.floating] | None = None
    ) -> NDArray[np.float64]:
        """:meth:`batch` in numpy: the readable reference of the compiled loop."""
        cam, model = self.camera, self.model
        p_opt = np.einsum("mij,pj->pmi", self.R, centres_base) + self.t  # (P, M, 3)
        if semi_up is not None:
            pred = np.stack(
                [
                    np.stack(
                        [
                            predict_spheroid_boxes(cam, p_opt[p, m][None], [a], [b], self.up_optical[m])[0][0, 0]
                            for m in range(len(self.R))
                        ]
                    )
                    for p, (a, b) in enumerate(zip(radii, semi_up))
                ]
            )
        elif cam.distortion_model == "none":
            pred = pinhole_sphere_boxes(cam, p_opt, radii[:, None])
        else:
            pred = np.stack([predict_sphere_boxes(cam, p, np.array([r]))[0][:, 0, :] for p, r in zip(p_opt, radii)])
        d = inward_edge_offsets(pred, self.obs)
        d = np.where(self.censored, np.minimum(d, 0.0), d)
        e = d / box_edge_sigma_px(model, pred, self.extra)
        return np.nan_to_num(e, nan=UNDEFINED_RESIDUAL).reshape(len(e), -1)


class _SphereResiduals:
    """Residuals of a fixed set of observations (boxes, and masks where used) for many ``(x, y, z, log r)`` at once.

    Everything that does not depend on the sphere (stacked poses and boxes,
    the contour points' viewing rays) is computed once; :meth:`batch`
    evaluates several parameter vectors in one numpy pass, which makes the
    forward-difference Jacobian one call instead of four (:func:`monovisual3d.geometry.levenberg.forward_jacobian`).
    Box residuals come first, then each mask's, in observation order.
    """

    def __init__(self, camera: Camera, observations: Sequence[Observation], model: SensorModel, use_masks: bool = True) -> None:
        self.camera, self.model = camera, model
        with_mask = [use_masks and ob.contour_uv is not None for ob in observations]
        boxes = [ob for ob, m in zip(observations, with_mask) if not m]
        self.boxes = _BoxResiduals(camera, boxes, model) if boxes else None
        self.masks = [
            (ob.T_optical_base[:3, :3], ob.T_optical_base[:3, 3], camera.rays(ob.contour_uv), float(ob.extra_sigma_px))
            for ob, m in zip(observations, with_mask)
            if m
        ]

    def batch(self, centres_base: NDArray[np.floating], radii: NDArray[np.floating]) -> NDArray[np.float64]:
        """Residuals for centres (P, 3), metres, base frame, and radii (P,), metres: shape (P, n)."""
        parts = [] if self.boxes is None else [self.boxes.batch(centres_base, radii)]
        for R, t, rays, extra in self.masks:
            parts.append(mask_residuals_rays(self.camera, centres_base @ R.T + t, radii, rays, self.model, extra))
        return np.concatenate(parts, axis=1) if parts else np.zeros((len(radii), 0))

    def params_batch(self, P: NDArray[np.floating]) -> NDArray[np.float64]:
        """Residuals (P, n) for parameter vectors ``P`` (P, 4) of ``(x, y, z, log r)``.

        A trial step far out (a depth the views hardly constrain) may overflow the radius: its residuals are then
        the stand-in of an undefined one (``UNDEFINED_RESIDUAL``) or not finite, and the solver rejects the step."""
        with np.errstate(over="ignore"):
            radii = np.exp(P[:, 3])
        return self.batch(P[:, :3], radii)

    def __call__(self, params: NDArray[np.floating]) -> NDArray[np.float64]:
        """Residuals (n,) for ``params = (x, y, z, log r)``."""
        return self.params_batch(np.asarray(params, dtype=float)[None])[0]


def one_sided_residuals(e: NDArray[np.floating], inward_floor: float, outward_floor: float) -> NDArray[np.float64]:
    """Normalised residuals ``e`` (positive: the observed edge inside the prediction) mapped so that their squares
    are the redescending loss of the module docstring with the floor ``inward_floor`` for ``e > 0`` and
    ``outward_floor`` otherwise: ``sign(e) sqrt(rho(e^2))``. Plain least squares on these minimises a mixture
    likelihood per edge, a Gaussian plus a flat tail whose level (``exp(-floor)`` of the peak) is the prior odds of a
    cut inward and of an outlier outward; near 0 they are ``e / sqrt(1 + exp(-floor))``, as scipy's robust loss
    scales them."""
    e = np.asarray(e, dtype=float)
    eps = np.where(e > 0, math.exp(-inward_floor), math.exp(-outward_floor))
    rho = -2.0 * (np.log(np.exp(-0.5 * e * e) + eps) - np.log1p(eps))
    return np.sign(e) * np.sqrt(np.maximum(rho, 0.0))


class _OneSidedResiduals(_SphereResiduals):
    """:class:`_SphereResiduals` through :func:`one_sided_residuals` (fitted with a plain squared loss)."""

    def __init__(
        self,
        camera: Camera,
        observations: Sequence[Observation],
        model: SensorModel,
        floors: tuple[float, float],
        use_masks: bool = True,
    ) -> None:
        super().__init__(camera, observations, model, use_masks)
        self.floors = floors

    def batch(self, centres_base: NDArray[np.floating], radii: NDArray[np.floating]) -> NDArray[np.float64]:
        return one_sided_residuals(super().batch(centres_base, radii), *self.floors)


#: Most residual evaluations of one refinement (well-posed ones converge in under 20).
MAX_NFEV = 60
#: A meaningful change of each parameter: 1 cm of the centre, 10 % of the radius (its log) and of the semi-axis up.
SPHERE_X_SCALE = np.array([0.01, 0.01, 0.01, 0.1])
SPHEROID_X_SCALE = np.array([0.01, 0.01, 0.01, 0.1, 0.1])
SPHERE_X_SCALE.flags.writeable = SPHEROID_X_SCALE.flags.writeable = False
#: Smallest radius (metres) a refinement starts from (its log is a parameter): 0.1 mm.
MIN_START_RADIUS_M = 1e-4


def refine_sphere(
    camera: Camera,
    observations: Sequence[Observation],
    centre0: NDArray[np.floating],
    radius0: float,
    model: SensorModel,
    *,
    use_masks: bool = True,
    floors: tuple[float, float] | None = None,
) -> Refined:
    """Refine centre and radius from at least two associated observations.

    ``floors`` ``(inward, outward)``, nats: the loss's floor by the residual's sign (:func:`one_sided_residuals`);
    None: ``inward_floor`` on both sides.

    Returns
    -------
    Refined
        ``covariance`` is ``(J^T J)^-1`` at the solution, with ``J`` the
        Jacobian the solver returns already scaled by the robust loss (outliers
        carry little weight): the Gauss-Newton approximation of the posterior
        covariance of the position.
    """
    x0 = np.concatenate([np.asarray(centre0, dtype=float), [np.log(max(radius0, MIN_START_RADIUS_M))]])
    # residuals and the forward-difference Jacobian in batched numpy passes
    if floors is None:
        fun = _SphereResiduals(camera, observations, model, use_masks)
    else:
        fun = _OneSidedResiduals(camera, observations, model, floors, use_masks)
    sol = levenberg_marquardt(
        fun.params_batch,
        x0,
        SPHERE_X_SCALE,
        loss=robust_loss(model.inward_floor) if floors is None else None,
        max_nfev=MAX_NFEV,  # bounded: near-degenerate views (depth unconstrained) otherwise wander for 400 evaluations
    )
    # the solver returns the Jacobian already scaled by the robust loss (J^T J is its
    # Gauss-Newton Hessian), so no further weighting here
    J = sol.jac
    H = J.T @ J
    try:
        cov_full = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        cov_full = np.full((4, 4), np.nan)
    r = float(np.exp(sol.x[3]))
    return Refined(
        centre=sol.x[:3].copy(),
        radius=r,
        covariance=cov_full[:3, :3],
        radius_std=float(r * np.sqrt(max(cov_full[3, 3], 0.0))) if np.isfinite(cov_full[3, 3]) else float("nan"),
        cost=float(sol.cost),
        success=bool(sol.success),
    )


class _SpheroidResiduals:
    """Box residuals of upright spheroids for ``params = (x, y, z, log a, log b)`` (masks are not used)."""

    def __init__(self, camera: Camera, observations: Sequence[Observation], model: SensorModel, up: NDArray[np.floating]) -> None:
        self.boxes = _BoxResiduals(camera, observations, model, up)

    def batch(self, P: NDArray[np.floating]) -> NDArray[np.float64]:
        with np.errstate(over="ignore"):  # see _SphereResiduals.params_batch
            a, b = np.exp(P[:, 3]), np.exp(P[:, 4])
        return self.boxes.batch(P[:, :3], a, b)

    def __call__(self, params: NDArray[np.floating]) -> NDArray[np.float64]:
        return self.batch(params[None, :])[0]


def refine_spheroid(
    camera: Camera,
    observations: Sequence[Observation],
    centre0: NDArray[np.floating],
    radius0: float,
    semi_up0: float,
    model: SensorModel,
    up: NDArray[np.floating],
) -> Refined:
    """Refine an upright spheroid (centre, semi-axis across ``up``, semi-axis along it) from its boxes.

    The search's elongated hypotheses go through this instead of :func:`refine_sphere` (same robust loss;
    masks are not used, the shape stage fits the final shape). ``covariance`` is the centre's block of
    ``(J^T J)^-1``; ``radius_std`` is that of the semi-axis across ``up``.
    """
    x0 = np.concatenate(
        [np.asarray(centre0, dtype=float), np.log([max(radius0, MIN_START_RADIUS_M), max(semi_up0, MIN_START_RADIUS_M)])]
    )
    fun = _SpheroidResiduals(camera, observations, model, up)
    sol = levenberg_marquardt(fun.batch, x0, SPHEROID_X_SCALE, loss=robust_loss(model.inward_floor), max_nfev=MAX_NFEV)
    try:
        cov_full = np.linalg.inv(sol.jac.T @ sol.jac)
    except np.linalg.LinAlgError:
        cov_full = np.full((5, 5), np.nan)
    a, b = float(np.exp(sol.x[3])), float(np.exp(sol.x[4]))
    std = float(a * np.sqrt(max(cov_full[3, 3], 0.0))) if np.isfinite(cov_full[3, 3]) else float("nan")
    return Refined(sol.x[:3].copy(), a, cov_full[:3, :3], std, float(sol.cost), bool(sol.success), semi_up=b)
