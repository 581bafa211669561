"""Joint refinement of all objects and a small pose correction per view (bundle adjustment with priors).

Arm kinematics and hand-eye calibration are never exact: the camera pose
reported for a view differs from the true one by a small rigid motion, and
every fruit seen in that view shares that error. Refining each fruit on its
own (:mod:`.refine`) cannot tell a shifted view from a shifted fruit; fitting
all fruit and every view's correction at once lets the views that agree
outvote the one that is off.

Model
-----
The true optical frame of view ``v`` is the reported one moved by a small
correction, ``p_true = exp([w_v]x) @ p_reported + t_v``: a rotation vector
``w_v`` (radians) and a translation ``t_v`` (metres), both in the view's
optical frame. Prior: ``w_v ~ N(0, rotation_sigma^2 I3)`` and ``t_v ~ N(0,
position_sigma^2 I3)``, the error model of
:func:`monovisual3d.sim.noise.perturb_pose` (a reported pose ``[R exp([e]x),
p + d]`` gives ``w = e`` and ``t = R^T d``, and an isotropic position error
stays isotropic in any frame).

Unknowns: ``(x, y, z, log r)`` per object (base frame, metres) and the
active pose parameters per view (rotation if ``rotation_sigma > 0``,
translation if ``position_sigma > 0``). Residuals: the normalised box-edge
(or mask) residuals of every associated (object, view) pair, computed by
:func:`monovisual3d.methods.bayes.refine.observation_residuals` under the robust
loss of :mod:`.refine`, and the prior residuals ``w_v / rotation_sigma`` and
``t_v / position_sigma`` as plain squares. The edge noise carries no pose
term here (the poses are unknowns, not noise). Each residual touches one
object and one view, so the finite-difference Jacobian perturbs the same
parameter of all objects (or of all views) at once: ``4 + 6`` residual
evaluations per Jacobian whatever the number of objects and views
(:func:`grouped_jacobian`). The Jacobian is handed to
:func:`scipy.optimize.least_squares` dense, for its exact trust-region
solver: the problem is small (``4 N + 6 V`` unknowns) but ill-conditioned
(the gauge below), on which the iterative sparse solver (LSMR) stalls for
hundreds of iterations.

The solve is graduated: first with the pose uncertainty projected into the
image as extra edge noise (while the corrections are still zero, box offsets
that the poses explain must not be taken for outliers by the robust loss),
then without it, from that solution.

Covariance: the inverse of the Gauss-Newton Hessian ``J^T W J`` at the
solution (``W``: the robust loss's weights; 1 for the priors); an object's
position covariance is its marginal 3x3 block, which includes the
uncertainty of the poses it was seen from.

What it cannot do: moving the whole scene and all cameras by one rigid
motion explains the boxes equally well, so only the priors fix that part of
the pose errors; an error common to all views (e.g. a hand-eye offset)
remains in the positions. What it removes is the disagreement between views.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...errors import InputError
from ...geometry.sphere import predict_sphere_boxes
from .likelihood import edge_residuals, pose_sigma_px
from .refine import MIN_START_RADIUS_M, SPHERE_X_SCALE, Observation, observation_residuals, robust_loss
from .sensor import UNDEFINED_RESIDUAL, SensorModel

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult


@dataclass
class Bundle:
    """Solution of :func:`bundle_adjust`.

    Attributes
    ----------
    centres : ndarray, shape (N, 3), metres, base frame
    radii : ndarray, shape (N,), metres
    covariances : ndarray, shape (N, 3, 3), m^2, base frame, marginal position covariance per object
    radius_std : ndarray, shape (N,), metres
    rotvec_optical : ndarray, shape (V, 3), radians, rotation correction per view (0 for views without observations)
    translation_optical : ndarray, shape (V, 3), metres, translation correction per view
    pose_std : ndarray, shape (V, 6), posterior std of ``(rotvec_optical, translation_optical)``: the prior's
        for views without observations, 0 for the parts taken as exact (sigma 0)
    cost : float, final value of the (robust) cost
    success : bool
    nfev : int, residual evaluations
    """

    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    covariances: NDArray[np.float64]
    radius_std: NDArray[np.float64]
    rotvec_optical: NDArray[np.float64]
    translation_optical: NDArray[np.float64]
    pose_std: NDArray[np.float64]
    cost: float
    success: bool
    nfev: int

    def T_corrected_reported(self, view: int) -> NDArray[np.float64]:
        """The correction of one view as a transform, shape (4, 4): ``p_optical_true = T @ p_optical_reported``."""
        return correction_transform(self.rotvec_optical[view], self.translation_optical[view])


def correction_transform(rotvec_optical: NDArray[np.floating], translation_optical: NDArray[np.floating]) -> NDArray[np.float64]:
    """Pose correction as a 4x4 transform ``T_corrected_reported`` (see the module docstring).

    The corrected pose of a view is ``T_optical_base = T_corrected_reported @
    T_optical_base_reported``.

    Parameters
    ----------
    rotvec_optical : ndarray, shape (3,), radians
    translation_optical : ndarray, shape (3,), metres

    Examples
    --------
    >>> correction_transform(np.zeros(3), np.array([0.0, 0.0, 0.001]))[:3, 3]
    array([0.   , 0.   , 0.001])
    """
    from scipy.spatial.transform import Rotation  # on first use: a localisation without pose corrections never needs it

    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.asarray(rotvec_optical, dtype=float)).as_matrix()
    T[:3, 3] = np.asarray(translation_optical, dtype=float)
    return T


def _mixed_loss(floor: float, n_robust: int) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """The robust loss of :mod:`.refine` on the first ``n_robust`` residuals, the plain square on the rest (priors)."""
    rho = robust_loss(floor)

    def loss(z: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty((3, len(z)))
        out[:, :n_robust] = rho(z[:n_robust])
        out[0, n_robust:] = z[n_robust:]
        out[1, n_robust:] = 1.0
        out[2, n_robust:] = 0.0
        return out

    return loss


def grouped_jacobian(
    fun: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    x: NDArray[np.float64],
    col_owner: Sequence[NDArray[np.int_]],
    n_par: int,
) -> NDArray[np.float64]:
    """Forward-difference Jacobian of ``fun`` at ``x`` with columns perturbed in groups.

    Parameters
    ----------
    fun : callable, x (n_par,) -> residuals (m,)
    x : ndarray, shape (n_par,)
    col_owner : sequence of ndarray, shape (m,), int
        One entry per group of columns that are perturbed together: for each
        row, the one column of the group it depends on (-1: none). Every
        column must appear in exactly one group.
    n_par : int

    Returns
    -------
    J : ndarray, shape (m, n_par), dense
    """
    f0 = fun(x)
    J = np.zeros((len(f0), n_par))
    h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
    for owner in col_owner:
        cols = np.unique(owner[owner >= 0])
        if not len(cols):
            continue
        xp = x.copy()
        xp[cols] += h[cols]
        rows = np.flatnonzero(owner >= 0)
        J[rows, owner[rows]] = (fun(xp)[rows] - f0[rows]) / h[owner[rows]]
    return J


def bundle_adjust(
    camera: Camera,
    observations: Sequence[tuple[int, int, Observation]],
    centres0: NDArray[np.floating],
    radii0: NDArray[np.floating],
    model: SensorModel,
    *,
    position_sigma: float,
    rotation_sigma: float,
    use_masks: bool = True,
    n_views: int | None = None,
) -> Bundle:
    """Refine all objects and a pose correction per view jointly (see the module docstring).

    Parameters
    ----------
    camera : Camera
    observations : sequence of ``(object index, view index, Observation)``
        Every associated (object, view) pair. ``Observation.T_optical_base``
        is the view's reported pose (the same for all pairs of a view);
        ``Observation.extra_sigma_px`` is used as given, so leave the pose
        term out of it (the poses are unknowns here).
    centres0 : ndarray, shape (N, 3), metres, base frame, starting centres
    radii0 : ndarray, shape (N,), metres, starting radii
    model : SensorModel
    position_sigma : float, metres, prior std of the camera position per axis (0: positions exact)
    rotation_sigma : float, radians, prior std of the camera rotation per axis (0: rotations exact)
    use_masks : bool, use the observations' mask contours where present
    n_views : int, optional, number of views (default: the largest view index + 1)

    Returns
    -------
    Bundle

    Examples
    --------
    >>> from monovisual3d.camera import Camera
    >>> from monovisual3d.frames import invert_transform, look_at
    >>> from monovisual3d.geometry.sphere import sphere_bbox
    >>> cam = Camera.from_hfov(640, 480, 69.0)
    >>> c, r = np.array([0.7, 0.0, 0.5]), 0.03
    >>> poses = [look_at(c + [-0.5, 0, 0], c), look_at(c + [-0.45, 0.15, -0.15], c)]
    >>> obs = [(0, v, Observation(invert_transform(T), sphere_bbox(cam, T, c[None], np.array([r]))[0])) for v, T in enumerate(poses)]
    >>> b = bundle_adjust(cam, obs, c[None] + 0.002, np.array([r]), SensorModel(), position_sigma=0.002, rotation_sigma=0.005)
    >>> bool(np.linalg.norm(b.centres[0] - c) < 1e-3)
    True
    """
    centres0, radii0, obs, n_views = _checked_inputs(centres0, radii0, observations, position_sigma, rotation_sigma, n_views)
    problem = _BundleProblem.build(
        camera, obs, len(centres0), model, position_sigma=position_sigma, rotation_sigma=rotation_sigma, use_masks=use_masks
    )
    sol, nfev = _graduated_solve(problem, centres0, radii0)
    return _pack_bundle(problem, sol, nfev, n_views)


def _checked_inputs(
    centres0: NDArray[np.floating],
    radii0: NDArray[np.floating],
    observations: Sequence[tuple[int, int, Observation]],
    position_sigma: float,
    rotation_sigma: float,
    n_views: int | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[tuple[int, int, Observation]], int]:
    """Validate the inputs of :func:`bundle_adjust` (raising :class:`InputError`).

    Returns
    -------
    centres0 : ndarray, shape (N, 3), float64, metres, base frame
    radii0 : ndarray, shape (N,), float64, metres
    obs : list of ``(object index, view index, Observation)``, in the given order
    n_views : int, the given one or the largest view index + 1
    """
    centres0 = np.asarray(centres0, dtype=float).reshape(-1, 3)
    radii0 = np.asarray(radii0, dtype=float).reshape(-1)
    n_obj = len(centres0)
    if len(radii0) != n_obj:
        raise InputError(f"radii0: got {len(radii0)} radii for {n_obj} centres")
    for name, value in (("position_sigma", position_sigma), ("rotation_sigma", rotation_sigma)):
        if not (np.isfinite(value) and value >= 0):
            raise InputError(f"{name}: got {value!r}, expected a finite number >= 0")
    obs = list(observations)
    if not obs:
        raise InputError("observations: got none, expected at least one (object, view, Observation)")
    if any(not (0 <= i < n_obj) or v < 0 for i, v, _ in obs):
        raise InputError("observations: object indices must lie in [0, N) and view indices be >= 0")
    last_view = max(v for _, v, _ in obs)
    n_views = last_view + 1 if n_views is None else int(n_views)
    if last_view >= n_views:
        raise InputError(f"observations: view index {last_view} >= n_views={n_views}")
    return centres0, radii0, obs, n_views


@dataclass(frozen=True, eq=False)
class _BundleProblem:
    """The least-squares problem of :func:`bundle_adjust`: parameter layout, residuals and Jacobian structure.

    Parameter vector ``x``: ``(x, y, z, log r)`` per object (base frame,
    metres), then per seen view (ascending) its active pose parameters
    (``rotvec_optical`` if ``rotation_sigma > 0``, ``translation_optical`` if
    ``position_sigma > 0``). Residual rows: 4 per box pair (all box pairs
    first, evaluated in one batch), one per contour point for each mask pair
    (one by one), then ``n_act`` prior rows per seen view.

    Attributes
    ----------
    camera : Camera
    model : SensorModel
    use_masks : bool
    position_sigma, rotation_sigma : float, metres / radians, the priors' std per axis
    n_obj : int, number of objects N
    seen : tuple of int, the views with observations, ascending
    active : ndarray, shape (6,), bool, which of ``(rotvec, translation)`` are unknowns
    sigmas : ndarray, shape (n_act,), prior std of the active pose parameters
    view_col : dict, view -> column of its first pose parameter in ``x``
    obs : list of ``(object, view, Observation)``, box pairs first, then mask pairs
    n_box : int, number of box pairs (the first ``n_box`` of ``obs``)
    box_obj : ndarray, shape (n_box,), int, object of each box pair
    box_view : list of int, view of each box pair
    box_T : ndarray, shape (n_box, 3, 4), reported ``T_optical_base[:3]`` of each box pair
    box_xyxy : ndarray, shape (n_box, 4), pixels, observed boxes
    box_extra : ndarray, shape (n_box,), pixels, the observations' ``extra_sigma_px``
    mask_obs : list of Observation, the mask pairs' observations
    """

    camera: Camera
    model: SensorModel
    use_masks: bool
    position_sigma: float
    rotation_sigma: float
    n_obj: int
    seen: tuple[int, ...]
    active: NDArray[np.bool_]
    sigmas: NDArray[np.float64]
    view_col: dict[int, int]
    obs: list[tuple[int, int, Observation]]
    n_box: int
    box_obj: NDArray[np.int_]
    box_view: list[int]
    box_T: NDArray[np.float64]
    box_xyxy: NDArray[np.float64]
    box_extra: NDArray[np.float64]
    mask_obs: list[Observation]

    @classmethod
    def build(
        cls,
        camera: Camera,
        observations: list[tuple[int, int, Observation]],
        n_obj: int,
        model: SensorModel,
        *,
        position_sigma: float,
        rotation_sigma: float,
        use_masks: bool,
    ) -> _BundleProblem:
        """Lay out the parameters and sort the pairs into box pairs (batched) and mask pairs (see the class docstring)."""
        seen = tuple(sorted({v for _, v, _ in observations}))
        active = np.array([rotation_sigma > 0] * 3 + [position_sigma > 0] * 3)
        sigmas = np.array([rotation_sigma] * 3 + [position_sigma] * 3)[active]
        n_act = int(active.sum())
        is_mask = [use_masks and ob.contour_uv is not None for _, _, ob in observations]
        obs = [o for o, m in zip(observations, is_mask) if not m] + [o for o, m in zip(observations, is_mask) if m]
        n_box = len(is_mask) - sum(is_mask)
        return cls(
            camera=camera,
            model=model,
            use_masks=use_masks,
            position_sigma=position_sigma,
            rotation_sigma=rotation_sigma,
            n_obj=n_obj,
            seen=seen,
            active=active,
            sigmas=sigmas,
            view_col={v: 4 * n_obj + k * n_act for k, v in enumerate(seen)},
            obs=obs,
            n_box=n_box,
            box_obj=np.array([i for i, _, _ in obs[:n_box]], dtype=int),
            box_view=[v for _, v, _ in obs[:n_box]],
            box_T=np.array([ob.T_optical_base[:3, :4] for _, _, ob in obs[:n_box]]).reshape(-1, 3, 4),
            box_xyxy=np.array([ob.bbox_xyxy for _, _, ob in obs[:n_box]]).reshape(-1, 4),
            box_extra=np.array([ob.extra_sigma_px for _, _, ob in obs[:n_box]]),
            mask_obs=[ob for _, _, ob in obs[n_box:]],
        )

    @property
    def n_act(self) -> int:
        """Number of pose parameters per seen view (0, 3 or 6)."""
        return int(self.active.sum())

    @property
    def n_par(self) -> int:
        """Length of the parameter vector."""
        return 4 * self.n_obj + self.n_act * len(self.seen)

    @property
    def row_sizes(self) -> list[int]:
        """Residual rows of each pair of :attr:`obs`: 4 per box, one per contour point."""
        return [4] * self.n_box + [len(ob.contour_uv) for _, _, ob in self.obs[self.n_box :]]

    @property
    def n_data(self) -> int:
        """Number of observation rows (before the prior rows)."""
        return int(sum(self.row_sizes))

    def x0(self, centres0: NDArray[np.float64], radii0: NDArray[np.float64]) -> NDArray[np.float64]:
        """Starting parameters: the given objects (radii floored at 0.1 mm), zero pose corrections."""
        x0 = np.zeros(self.n_par)
        x0[: 4 * self.n_obj] = np.column_stack([centres0, np.log(np.maximum(radii0, MIN_START_RADIUS_M))]).ravel()
        return x0

    def x_scale(self) -> NDArray[np.float64]:
        """Characteristic scale of each parameter: 1 cm per coordinate, 0.1 per log radius, the prior std per pose part."""
        return np.concatenate([np.tile(SPHERE_X_SCALE, self.n_obj), np.tile(self.sigmas, len(self.seen))])

    def unpack(
        self, x: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]]]:
        """Objects, shape (N, 4) ``(x, y, z, log r)``, and per seen view its correction ``(R, t)``: (3, 3), (3,)."""
        from scipy.spatial.transform import Rotation

        obj = x[: 4 * self.n_obj].reshape(self.n_obj, 4)
        n_act = self.n_act
        poses = {}
        for v in self.seen:
            p6 = np.zeros(6)
            p6[self.active] = x[self.view_col[v] : self.view_col[v] + n_act]
            poses[v] = (Rotation.from_rotvec(p6[:3]).as_matrix() if self.rotation_sigma > 0 else np.eye(3), p6[3:])
        return obj, poses

    def residuals(
        self, x: NDArray[np.float64], box_extra: NDArray[np.float64], mask_obs: list[Observation]
    ) -> NDArray[np.float64]:
        """All residuals at ``x``, with ``box_extra`` / ``mask_obs`` in place of the attributes (their edge noise)."""
        obj, poses = self.unpack(x)
        camera, n_box, n_act = self.camera, self.n_box, self.n_act
        out = []
        if n_box:
            c = obj[self.box_obj]
            p_rep = np.einsum("pij,pj->pi", self.box_T[:, :, :3], c[:, :3]) + self.box_T[:, :, 3]
            R = np.array([poses[v][0] for v in self.box_view])
            t = np.array([poses[v][1] for v in self.box_view])
            p_opt = np.einsum("pij,pj->pi", R, p_rep) + t
            pred, _ = predict_sphere_boxes(camera, p_opt, np.exp(c[:, 3:4]))
            e = edge_residuals(pred[:, 0], self.box_xyxy, self.model, camera.width, camera.height, box_extra)
            out.append(np.nan_to_num(e, nan=UNDEFINED_RESIDUAL).ravel())
        for (i, v, _), ob in zip(self.obs[n_box:], mask_obs):
            R, t = poses[v]
            T = ob.T_optical_base
            p_opt = R @ (T[:3, :3] @ obj[i, :3] + T[:3, 3]) + t
            out.append(observation_residuals(camera, p_opt, float(np.exp(obj[i, 3])), ob, self.model, self.use_masks))
        prior = [x[self.view_col[v] : self.view_col[v] + n_act] / self.sigmas for v in self.seen]
        return np.concatenate(out + prior) if out or prior else np.zeros(0)

    def column_owners(self) -> list[NDArray[np.int_]]:
        """For :func:`grouped_jacobian`: per group of columns perturbed together, the column each row depends on.

        Groups: the 4 object parameters (all objects at once), then each
        active pose parameter (all views at once). A prior row depends on its
        view's own parameter only.
        """
        sizes, n_act, seen = self.row_sizes, self.n_act, self.seen
        row_obj = np.concatenate([np.full(k, i) for (i, _, _), k in zip(self.obs, sizes)] + [np.full(n_act * len(seen), -1)])
        row_view = np.concatenate([np.full(k, v) for (_, v, _), k in zip(self.obs, sizes)] + [np.repeat(seen, n_act)])
        row_prior = np.concatenate([np.full(self.n_data, -1), np.tile(np.arange(n_act), len(seen))])
        col_owner = []
        for k in range(4):
            col_owner.append(np.where(row_obj >= 0, 4 * row_obj + k, -1))
        for a in range(n_act):
            col = np.array([self.view_col.get(int(v), -1) + a for v in row_view])
            col_owner.append(np.where((row_prior < 0) | (row_prior == a), col, -1))
        return col_owner

    def inflated_noise(self, centres0: NDArray[np.float64]) -> tuple[NDArray[np.float64], list[Observation]]:
        """Edge noise with the pose uncertainty projected into the image at ``centres0`` added in quadrature.

        Returns the ``(box_extra, mask_obs)`` arguments of :meth:`residuals` for the first stage of the solve.
        """
        depth = np.array([ob.T_optical_base[2, :3] @ centres0[i] + ob.T_optical_base[2, 3] for i, _, ob in self.obs])
        pose_px = pose_sigma_px(self.camera, depth, self.position_sigma, self.rotation_sigma)
        inflated_box = np.hypot(self.box_extra, pose_px[: self.n_box])
        inflated_mask = [
            replace(ob, extra_sigma_px=float(np.hypot(ob.extra_sigma_px, e)))
            for ob, e in zip(self.mask_obs, pose_px[self.n_box :])
        ]
        return inflated_box, inflated_mask


def _graduated_solve(
    problem: _BundleProblem, centres0: NDArray[np.float64], radii0: NDArray[np.float64]
) -> tuple[OptimizeResult, int]:
    """Solve ``problem`` in two stages; returns the second stage's solution and the residual evaluations of both.

    First with the pose uncertainty as extra edge noise (while the
    corrections are still 0, box offsets that the poses explain must not be
    taken for outliers by the robust loss), then without, from that solution.
    """
    from scipy.optimize import least_squares  # on first use: 0.45 s to import, only pose corrections need it

    fun, col_owner, n_par = problem.residuals, problem.column_owners(), problem.n_par
    loss = _mixed_loss(problem.model.inward_floor, problem.n_data)
    x0, x_scale = problem.x0(centres0, radii0), problem.x_scale()
    nfev = 0
    for args in (problem.inflated_noise(centres0), (problem.box_extra, problem.mask_obs)):
        sol = least_squares(
            fun,
            x0,
            jac=lambda x, *a: grouped_jacobian(lambda y: fun(y, *a), x, col_owner, n_par),
            loss=loss,
            method="trf",
            tr_solver="exact",
            x_scale=x_scale,
            args=args,
        )
        x0, nfev = sol.x, nfev + sol.nfev
    return sol, nfev


def _pack_bundle(problem: _BundleProblem, sol: OptimizeResult, nfev: int, n_views: int) -> Bundle:
    """The :class:`Bundle` of a solution: estimates, and covariances from the Gauss-Newton Hessian at it."""
    n_obj, n_par, n_act, active = problem.n_obj, problem.n_par, problem.n_act, problem.active
    # sol.jac is already scaled by the loss (J^T J is scipy's Gauss-Newton Hessian of the robust cost)
    J = np.asarray(sol.jac)
    try:
        cov = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        cov = np.full((n_par, n_par), np.nan)
    obj = sol.x[: 4 * n_obj].reshape(n_obj, 4)
    radii = np.exp(obj[:, 3])
    covariances = np.stack([cov[4 * i : 4 * i + 3, 4 * i : 4 * i + 3] for i in range(n_obj)]) if n_obj else np.zeros((0, 3, 3))
    var_logr = np.array([cov[4 * i + 3, 4 * i + 3] for i in range(n_obj)])
    radius_std = radii * np.sqrt(np.where(np.isfinite(var_logr), np.maximum(var_logr, 0.0), np.nan))
    pose = np.zeros((n_views, 6))
    pose_std = np.tile(np.array([problem.rotation_sigma] * 3 + [problem.position_sigma] * 3, dtype=float), (n_views, 1))
    for v in problem.seen:
        sl = slice(problem.view_col[v], problem.view_col[v] + n_act)
        pose[v, active] = sol.x[sl]
        pose_std[v, active] = np.sqrt(np.maximum(np.diag(cov)[sl], 0.0))
    return Bundle(
        centres=obj[:, :3].copy(),
        radii=radii,
        covariances=covariances,
        radius_std=radius_std,
        rotvec_optical=pose[:, :3],
        translation_optical=pose[:, 3:],
        pose_std=pose_std,
        cost=float(sol.cost),
        success=bool(sol.success),
        nfev=int(nfev),
    )
