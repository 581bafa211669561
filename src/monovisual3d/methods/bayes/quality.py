"""The consistency model: every object's boxes against its fitted solid, under the sensor model, and an honest covariance.

The last pass (:data:`.pipeline.PASSES`). For each object it predicts the boxes of its fitted solid in the views that
hold its boxes (:func:`.aspects.solid_boxes`, all objects in one batched call) and normalises the residuals of the box
sides by the sensor model's edge noise (:func:`.sensor.box_edge_sigma_px`): ``z = (observed - predicted) / sigma``. An
edge on the image border says only that the object reaches that far and is left out
(:func:`.sensor.censored_edges`).

Chi-square and degrees of freedom
    Per object ``residual_chi2 = sum z^2`` over its ``n`` edges and ``dof = n - p`` (``p``: the parameters of its solid
    that the boxes determine: centre, its distinct semi-axes, a yaw where the solid has one). Per view, the same summed
    over the objects' boxes there, ``dof`` the edges' share (``1 - leverage`` each).

Variance factors
    Box sides are not independent: a detector's box moves as a whole (its centre) more than it grows (its size), so the
    two edges along an axis are correlated (the simulator's box noise: +0.6). The residuals along each axis are split
    into a centre part ``(z1 + z2) / sqrt 2`` and a size part ``(z2 - z1) / sqrt 2``, independent with variances
    ``f_centre`` and ``f_size`` (both 1 under the sensor model, which takes the edges as independent). The session's two
    factors are estimated by moments (:func:`variance_components`): the expected squared parts of each object's
    residuals ``r = M e`` (``M = I - H``, the fit's residual maker) are linear in the two factors, so the fitted
    parameters' share of the noise is accounted for exactly. Residuals beyond :data:`CLIP_SIGMAS` robust sigmas (a
    box cut by a leaf, one of another object) are clipped, so that a few do not set the session's scale.

Covariance
    The fit is a weighted least-squares fit under the sensor model's weights; its covariance under the session's noise
    is the sandwich ``A^-1 B A^-1`` with ``A = J^T J`` and ``B = J^T S J`` (``J``: the numeric Jacobian of the
    normalised residuals w.r.t. the solid's parameters, ``S``: the session's edge covariance), whose centre block is the
    position's (marginal over the size and yaw). Each object scales it by its own variance factor, shrunk toward the
    session's with :data:`PRIOR_DOF` degrees of freedom of prior (:func:`object_factor`; both ways: an object whose
    boxes sit closer to its fit than the session's is, on the evidence, better measured), and by ``1 + TAIL / dof``
    (dof: those the factor rests on, the object's and the prior's): a variance estimated from few degrees of freedom
    makes the error's distribution heavier-tailed (a Student-t's). An object fitted as a spheroid or an ellipsoid
    adds the spread toward the other reading of its boxes, a sphere whose boxes leaves cut (:func:`cut_spheres`): the
    two explain a box shortened on one side alike, and the fitted model's own covariance says nothing of the choice.
    A covariance that is not positive definite, or whose spread exceeds the object's distance to the cameras (every view
    from one place: depth along the line of sight is not determined), is reported as None with the reason.

Causes (:class:`~monovisual3d.verdict.Cause`)
    ``scatter`` when the session's variance factor is beyond :data:`SCATTER_FACTOR` on at least :data:`SCATTER_MIN_DOF`
    degrees of freedom (the boxes are scattered several times the sensor model's noise: a noisier detector, or a mistake
    no other test names); ``unexplained_boxes`` when at least :data:`UNEXPLAINED_SHARE` of the boxes, and
    :data:`UNEXPLAINED_MIN` or more, are held by no object.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ...geometry.ellipsoid import Ellipsoid, ellipsoid_bbox
from ...geometry.orientation import rotation_from_quaternion_xyzw
from ...verdict import Cause
from .aspects import object_boxes, solid_boxes
from .fits import Answer, as_answer, evidence_margin, predicted_boxes, sphere_answer
from .likelihood import box_scores, edge_residuals
from .occlusion import occlusion_flags
from .problem import Problem
from .refine import MIN_VIEWS_ONE_SIDED, refine_sphere
from .scoring import pose_px
from .sensor import box_edge_sigma_px, censored_edges
from .state import Found, ObjectQuality, Quality, State, ViewQuality

#: Degrees of freedom of the prior an object's variance factor is shrunk with toward the session's: an object's own
#: residuals (8 degrees of freedom from 3 views) say little alone; the session's say what the detector's noise is
#: (why: docs/decisions/bayes-quality.md#prior_dof).
PRIOR_DOF = 10.0
#: The covariance is scaled by ``1 + TAIL / dof`` (dof: those its variance factor rests on): the mean of an F(3, dof)
#: is ``dof / (dof - 2)``, so a variance estimated from few degrees of freedom still covers the error on average.
TAIL = 2.0
#: Residuals beyond this many robust sigmas (the median absolute residual scaled to a normal's) are clipped there
#: before the variance factors: a box a leaf cuts by ten sigmas counts as four.
CLIP_SIGMAS = 4.0
#: An object's own residuals are clipped at this many robust sigmas for its own variance factor: its box cut by a leaf
#: or taken from another fruit is evidence about it (where the session's scale must not follow one object), up to
#: where the fit's robust loss has set an edge aside altogether (why: docs/decisions/bayes-quality.md#object_clip_sigmas).
OBJECT_CLIP_SIGMAS = 10.0
#: The normal's median absolute value: a robust sigma is ``median(|z|) / MAD_NORMAL``.
MAD_NORMAL = 0.6745
#: Degrees of freedom of the session before the centre and size factors are told apart (fewer: one factor for both;
#: why: docs/decisions/bayes-quality.md#centre-and-size-factors).
MIN_DOF_COMPONENTS = 24
#: Relative step of the numeric Jacobian (of the semi-axes' logarithms, of the position in units of the size, of the
#: yaw in radians).
STEP = 1e-4
#: A column of the Jacobian this small against the largest is a parameter the boxes do not see (an upright spheroid's
#: yaw), left out.
NULL_COLUMN = 1e-7
#: A covariance whose largest standard deviation exceeds this share of the object's distance to its nearest camera
#: is no estimate: the boxes do not determine the depth (every view from one place).
UNDETERMINED_SHARE = 0.5
#: ``scatter`` fires when the session's variance factor (1 under the sensor model) exceeds this: edge noise four times
#: the model's (box noise of about 20 % of the box size where the model says 5 %;
#: why: docs/decisions/bayes-quality.md#scatter_factor).
SCATTER_FACTOR = 16.0
#: Degrees of freedom the session's variance factor must rest on before ``scatter`` fires (few boxes: no evidence).
SCATTER_MIN_DOF = 12
#: Largest argument given to ``math.exp`` (a margin of 700 nats is certainty; beyond, exp overflows).
MAX_EXP = 700.0
#: Cosine of the largest angle between the outward directions, in the base frame, of one box side (the same image side)
#: in two views for their cuts to be one occluder's (:func:`repeated_cuts`): 25 degrees, neighbouring views of an arc
#: (10-30 degrees apart), not the far side of a ring of views. A 60-degree cone grouped one view's bottom edge with
#: two others' right edges on the real Aldoma set's tilted views (why: docs/decisions/bayes-quality.md#one-occluder-one-cost).
SHARED_CUT_COS = math.cos(math.radians(25.0))
#: Each box side's outward direction in the optical frame, in ``bbox_xyxy`` order: x1 left (-x), y1 up (-y), x2 right
#: (+x), y2 down (+y).
SIDE_DIRECTIONS_OPTICAL = np.array([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
#: ``unexplained_boxes`` fires when at least this share of the boxes is held by no object...
UNEXPLAINED_SHARE = 1.0 / 3.0
#: ...and at least this many.
UNEXPLAINED_MIN = 6


@dataclass(frozen=True)
class _Fit:
    """One object's normalised residuals and Jacobian over its edges used.

    Attributes
    ----------
    z : ndarray, shape (n,), normalised residuals
    J : ndarray, shape (n, p), d(predicted edge / sigma) / d(parameter); columns 0-2 the centre (metres)
    pairs : ndarray, shape (n,), int: the partner edge's row (the other edge along the same axis of the box), -1: none
    views : ndarray, shape (n,), int: session view index of each edge
    distance : float, metres: to the nearest camera
    """

    z: NDArray[np.float64]
    J: NDArray[np.float64]
    pairs: NDArray[np.intp]
    views: NDArray[np.intp]
    distance: float


def _perturbations(
    problem: Problem, o: Found
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], list[float]]:
    """The object's solid moved along each parameter both ways: centres (2P+1, 3), semi-axes (2P+1, 3), rotations
    (2P+1, 3, 3), and the steps (P,): the unmoved solid first, then ``+step, -step`` of each parameter."""
    semi = np.asarray(o.semi_axes if o.semi_axes is not None else [o.radius] * 3, dtype=float)
    R = rotation_from_quaternion_xyzw(o.quaternion_xyzw) if o.quaternion_xyzw is not None else np.eye(3)
    size = float(np.max(semi))
    groups: list[NDArray[np.bool_]] = []
    for a in range(3):
        if not any(g[a] for g in groups):
            groups.append(np.isclose(semi, semi[a], rtol=1e-6))
    up = np.asarray(problem.config.up_vector, dtype=float)
    centres, semis, rots, steps = [o.position], [semi], [R], []
    for k in range(3):
        d = np.zeros(3)
        d[k] = STEP * size
        centres += [o.position + d, o.position - d]
        semis += [semi, semi]
        rots += [R, R]
        steps.append(2 * STEP * size)
    for g in groups:
        centres += [o.position, o.position]
        semis += [semi * np.exp(STEP * g), semi * np.exp(-STEP * g)]
        rots += [R, R]
        steps.append(2 * STEP)
    if len(groups) > 1:  # a yaw about the vertical (zero where the solid is round about it)
        for s in (STEP, -STEP):
            K = np.array([[0, -up[2], up[1]], [up[2], 0, -up[0]], [-up[1], up[0], 0]]) * s
            centres.append(o.position)
            semis.append(semi)
            rots.append((np.eye(3) + K + 0.5 * K @ K) @ R)
        steps.append(2 * STEP)
    return np.array(centres), np.array(semis), np.array(rots), steps


def _predictions(problem: Problem, jobs: list[tuple]) -> dict[int, NDArray[np.float64]]:
    """The boxes (2P+1, K, 4), pixels, of each job's moved solids (:func:`_perturbations`) in its K views, by job index:
    every ellipsoid of every object in one batched call, a solid (cylinder, cuboid) on its own."""
    cam = problem.camera
    plain = [i for i, job in enumerate(jobs) if not job[0].solid and len(job[1])]
    preds: dict[int, NDArray[np.float64]] = {}
    if plain:
        P = [len(jobs[i][3]) for i in plain]
        K = [len(jobs[i][1]) for i in plain]
        poses = np.concatenate([np.repeat(jobs[i][1][None], p, axis=0).reshape(-1, 4, 4) for i, p in zip(plain, P)])
        centres = np.concatenate([np.repeat(jobs[i][3], k, axis=0) for i, k in zip(plain, K)])
        semis = np.concatenate([np.repeat(jobs[i][4], k, axis=0) for i, k in zip(plain, K)])
        rots = np.concatenate([np.repeat(jobs[i][5], k, axis=0) for i, k in zip(plain, K)])
        with np.errstate(invalid="ignore", divide="ignore"):
            flat = ellipsoid_bbox(cam, poses, centres, semis, rots, clip=False)
        start = 0
        for i, p, k in zip(plain, P, K):
            preds[i] = flat[start : start + p * k].reshape(p, k, 4)
            start += p * k
    for i, (o, poses, _, centres, semis, rots, _) in enumerate(jobs):
        if i not in preds and len(poses):
            with np.errstate(invalid="ignore", divide="ignore"):
                preds[i] = np.stack(
                    [solid_boxes(cam, poses, Ellipsoid.from_rotation(c, s, R), o.solid) for c, s, R in zip(centres, semis, rots)]
                )
    return preds


def _object_fits(problem: Problem, objects: tuple[Found, ...]) -> list[_Fit | None]:
    """:class:`_Fit` of each object (None: no edge to use)."""
    cam, model = problem.camera, problem.model
    jobs = []
    for o in objects:
        poses, boxes = object_boxes(problem, o)
        jobs.append((o, poses, boxes, *_perturbations(problem, o)))
    preds = _predictions(problem, jobs)
    out: list[_Fit | None] = []
    for i, (o, poses, boxes, _, _, _, steps) in enumerate(jobs):
        if i not in preds:
            out.append(None)
            continue
        pred = preds[i]
        T_optical_base = np.linalg.inv(poses)
        depth = T_optical_base[:, 2, :3] @ o.position + T_optical_base[:, 2, 3]
        extra = np.asarray(pose_px(problem, depth), dtype=float)
        sigma = box_edge_sigma_px(model, pred[0], extra)  # extra: per view, shape (V,) or a scalar
        z = (boxes - pred[0]) / sigma
        cols = [((pred[1 + 2 * k] - pred[2 + 2 * k]) / steps[k] / sigma).reshape(-1) for k in range(len(steps))]
        J = np.stack(cols, axis=1)
        used = ~censored_edges(boxes, cam.width, cam.height, model.border_px).reshape(-1)
        used &= np.isfinite(z.reshape(-1)) & np.all(np.isfinite(J), axis=1)
        norms = np.linalg.norm(J[used], axis=0) if used.any() else np.zeros(J.shape[1])
        keep = np.ones(J.shape[1], dtype=bool)
        keep[3:] = norms[3:] > NULL_COLUMN * max(float(norms.max(initial=0.0)), 1e-300)
        rows = np.flatnonzero(used)
        if not len(rows):
            out.append(None)
            continue
        partner = np.arange(4 * len(poses)).reshape(-1, 4)[:, [2, 3, 0, 1]].reshape(-1)
        where = np.full(4 * len(poses), -1)
        where[rows] = np.arange(len(rows))
        views = np.repeat(np.array(sorted(o.associations), dtype=np.intp), 4)
        cam_pos = poses[:, :3, 3]
        out.append(
            _Fit(
                z.reshape(-1)[rows],
                J[np.ix_(rows, np.flatnonzero(keep))],
                where[partner[rows]],
                views[rows],
                float(np.min(np.linalg.norm(cam_pos - o.position, axis=1))),
            )
        )
    return out


def _parts(n: int, pairs: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The centre and size quadratic forms (n, n) of the edges: ``0.5 [[1, 1], [1, 1]]`` and ``0.5 [[1, -1], [-1, 1]]``
    on each pair of edges along one axis of a box (an edge without its partner: 0.5 each)."""
    Pc, Ps = 0.5 * np.eye(n), 0.5 * np.eye(n)
    i = np.flatnonzero(pairs >= 0)
    Pc[i, pairs[i]] = 0.5
    Ps[i, pairs[i]] = -0.5
    return Pc, Ps


@dataclass(frozen=True)
class _Moments:
    """One object's residual maker and the traces the variance components are estimated from."""

    M: NDArray[np.float64]
    Pc: NDArray[np.float64]
    Ps: NDArray[np.float64]
    rank: int
    traces: NDArray[np.float64]  # [tr(Pc M Pc M), tr(Pc M Ps M), tr(Ps M Ps M), tr(M Pc M), tr(M Ps M)]


def _moments(fit: _Fit) -> _Moments:
    n = len(fit.z)
    Pc, Ps = _parts(n, fit.pairs)
    pinv = np.linalg.pinv(fit.J, rcond=1e-10)
    rank = int(np.linalg.matrix_rank(fit.J, tol=1e-10 * max(np.linalg.norm(fit.J, 2), 1e-300)))
    M = np.eye(n) - fit.J @ pinv
    McM, MsM = Pc @ M, Ps @ M
    traces = np.array([np.sum(McM * McM.T), np.sum(McM * MsM.T), np.sum(MsM * MsM.T), np.trace(M @ Pc @ M), np.trace(M @ Ps @ M)])
    return _Moments(M, Pc, Ps, rank, traces)


def variance_components(clipped: list[NDArray[np.float64]], moments: list[_Moments]) -> tuple[float, float, float, int]:
    """The session's centre and size factors, its single variance factor and degrees of freedom, by moments.

    ``E[r^T Pc r] = f_c tr(Pc M Pc M) + f_s tr(Pc M Ps M)`` and ``E[r^T Ps r] = f_c tr(Ps M Pc M) + f_s tr(Ps M Ps M)``
    summed over the objects; with fewer than :data:`MIN_DOF_COMPONENTS` degrees of freedom, or a solution that is not
    positive, one factor for both (``sum r^T r / sum dof``)."""
    dof = sum(len(z) - m.rank for z, m in zip(clipped, moments))
    chi2 = sum(float(z @ z) for z in clipped)
    if dof <= 0:
        return 1.0, 1.0, 1.0, 0
    single = chi2 / dof
    if dof < MIN_DOF_COMPONENTS:
        return single, single, single, dof
    qc = sum(float(z @ m.Pc @ z) for z, m in zip(clipped, moments))
    qs = sum(float(z @ m.Ps @ z) for z, m in zip(clipped, moments))
    T = sum(m.traces for m in moments)
    A = np.array([[T[0], T[1]], [T[1], T[2]]])
    try:
        fc, fs = np.linalg.solve(A, [qc, qs])
    except np.linalg.LinAlgError:
        return single, single, single, dof
    if not (fc > 0 and fs > 0):
        return single, single, single, dof
    return float(fc), float(fs), single, dof


def object_factor(chi2_rel: float, dof: int, prior_dof: float = PRIOR_DOF) -> float:
    """An object's variance factor relative to the session's: its own ``chi2_rel`` (its residuals' chi-square under the
    session's noise, ``dof`` degrees of freedom) shrunk toward 1 with ``prior_dof`` degrees of freedom of prior (the
    scaled inverse chi-square posterior's mean).

    >>> object_factor(8.0, 8)
    1.0
    >>> round(object_factor(40.0, 8), 2)
    2.78
    """
    return (prior_dof + chi2_rel) / (prior_dof + max(dof, 0))


def assess(problem: Problem, objects: tuple[Found, ...]) -> tuple[Quality, tuple[Found, ...]]:
    """The session's :class:`Quality` and the objects with their honest covariances (positions unchanged)."""
    fits = _object_fits(problem, objects)
    live = [f for f in fits if f is not None]
    n_boxes = sum(len(vd.boxes) for vd in problem.views)
    if not live:
        return Quality(
            objects=tuple(ObjectQuality(0.0, 0, 1.0, "no box edge to fit") for _ in objects),
            n_boxes=n_boxes,
            unexplained_boxes=tuple(unexplained_boxes(problem, objects, 1.0)),
        ), objects
    moments = {id(f): _moments(f) for f in live}
    all_z = np.concatenate([f.z for f in live])
    robust = max(float(np.median(np.abs(all_z))) / MAD_NORMAL, 1e-9)
    clip = CLIP_SIGMAS * robust
    clipped = {id(f): np.clip(f.z, -clip, clip) for f in live}
    fc, fs, single, dof = variance_components([clipped[id(f)] for f in live], [moments[id(f)] for f in live])

    obj_quality, out = [], []
    view_chi2: dict[int, list[float]] = {}
    others = cut_spheres(problem, objects)
    for o, f, other in zip(objects, fits, others):
        if f is None:
            obj_quality.append(ObjectQuality(0.0, 0, single, "no box edge to fit"))
            out.append(replace(o, covariance=None))
            continue
        m = moments[id(f)]
        S = fc * m.Pc + fs * m.Ps
        z = np.clip(f.z, -OBJECT_CLIP_SIGMAS * robust, OBJECT_CLIP_SIGMAS * robust)
        obj_dof = len(z) - m.rank
        expected = fc * m.traces[3] + fs * m.traces[4]  # E[r^T r] under the session's noise
        chi2_rel = float(z @ z) * obj_dof / expected if expected > 0 and obj_dof > 0 else 0.0
        prior = min(PRIOR_DOF, max(dof - obj_dof, 0))
        k = object_factor(chi2_rel, obj_dof, prior) if prior + obj_dof > 0 else 1.0
        tail = 1.0 + TAIL / max(prior + obj_dof, 1.0)  # the degrees of freedom the factor rests on
        cov, reason = _covariance(f, S, k * tail)
        if cov is not None and other is not None:
            cov = cov + other.spread
        factor = k * (fc * m.traces[3] + fs * m.traces[4]) / max(m.traces[3] + m.traces[4], 1e-300)
        obj_quality.append(ObjectQuality(float(f.z @ f.z), int(len(f.z) - m.rank), float(factor), reason))
        out.append(replace(o, covariance=cov))
        diag_M = np.diag(m.M @ S @ m.M)
        share = np.diag(m.M)  # each edge's share of the degrees of freedom: 1 - its leverage
        for v in np.unique(f.views):
            sel = f.views == v
            acc = view_chi2.setdefault(int(v), [0.0, 0.0, 0.0])
            acc[0] += float(f.z[sel] @ f.z[sel])
            acc[1] += float(np.sum(share[sel]))
            acc[2] += float(np.sum(diag_M[sel]))
    views = []
    for v in sorted(view_chi2):
        c, d, e = view_chi2[v]
        consistency = c / e if e > 0 else 1.0
        p = chi2_sf(consistency * d, d) if d > 0 else 1.0
        views.append(ViewQuality(v, c, d, consistency, p))
    free = tuple(unexplained_boxes(problem, objects, single))
    robust_factor = robust**2 * len(all_z) / dof if dof > 0 else 1.0
    quality = Quality(tuple(obj_quality), tuple(views), single, fc, fs, robust_factor, int(dof), free, n_boxes)
    return quality, tuple(out)


@dataclass(frozen=True)
class CutSphere:
    """The other reading of an object fitted as a spheroid or an ellipsoid: a sphere whose boxes leaves cut.

    Attributes
    ----------
    weight : float, the sphere's posterior probability against the object's model (0-1)
    offset : ndarray, shape (3,), metres, base frame: the sphere's centre less the object's position
    radius : float, metres: the sphere's radius
    """

    weight: float
    offset: NDArray[np.float64]
    radius: float

    @property
    def spread(self) -> NDArray[np.float64]:
        """``weight * offset offset^T`` (3, 3), m^2: what the reading adds to the position's covariance."""
        return self.weight * np.outer(self.offset, self.offset)


def cut_spheres(problem: Problem, objects: tuple[Found, ...]) -> list[CutSphere | None]:
    """Per object that the shape stage (``shape="auto"``) fitted as a spheroid or an ellipsoid (not a solid), the
    :class:`CutSphere` that explains its boxes the other way: a leaf only ever shortens a box, from one side, and a
    flattened model shortens it from both.

    The sphere is refitted from the object's position with the shape stage's one-sided loss (an edge inside its
    prediction a possible cut; :func:`.refine.refine_sphere` with ``floors``, the edges nearer objects cut censored by
    :func:`.occlusion.occlusion_flags` with every object as the sphere of its volume-equivalent radius), and weighed
    against the object's model by :func:`.fits.evidence_margin` ``m`` on every edge of the object's boxes (the shape
    stage counts the edges its fit used and lets hidden ones move), each reading's cuts of one side counted once
    (:func:`shared_cut_nats`), equal prior odds: ``weight = 1 / (1 + exp(m))``.
    The boxes alone are weighed, masks or not. None for the other objects, and where the one-sided refit does not apply
    (``tuning.one_sided_refit`` off, fewer than :data:`.refine.MIN_VIEWS_ONE_SIDED` views, an object refined jointly
    with the poses), the refit fails or leaves ``BayesConfig.fit_radius_range``, or the margin is not finite
    (why: docs/decisions/bayes-quality.md#a-cut-spheres-spread)."""
    cfg = problem.config
    out: list[CutSphere | None] = [None] * len(objects)
    todo = [i for i, o in enumerate(objects) if o.shape in ("spheroid", "ellipsoid") and o.solid is None]
    if not todo or cfg.shape != "auto" or not cfg.tuning.one_sided_refit:
        return out
    spheres = [  # each object as the sphere of its volume-equivalent radius (the search's elongation not carried over)
        Found(o.position, o.score, o.radius, o.covariance, o.associations, o.n_cells, pose_corrected=o.pose_corrected)
        for o in objects
    ]
    flags = occlusion_flags(problem, spheres)
    floors = (cfg.tuning.cut_inward_floor, problem.model.outward_floor)
    lo, hi = cfg.fit_radius_range
    for i in todo:
        o, f = objects[i], flags[i]
        if f is None or len(f[0]) < MIN_VIEWS_ONE_SIDED:
            continue
        radius = float(o.radius)  # type: ignore[arg-type]  # a fitted shape's volume-equivalent radius
        fit = refine_sphere(problem.camera, f[0], o.position, radius, problem.model, use_masks=False, floors=floors)
        if not (fit.success and np.all(np.isfinite(fit.centre)) and lo <= fit.radius <= hi):
            continue
        sphere = Found(np.asarray(fit.centre, dtype=float), o.score, float(fit.radius), associations=o.associations)
        model, other = as_answer(problem, o), sphere_answer(sphere)
        margin = evidence_margin(problem, o, model, other, 4 * len(o.associations))
        margin += shared_cut_nats(problem, o, model) - shared_cut_nats(problem, o, other)
        if math.isfinite(margin):
            out[i] = CutSphere(1.0 / (1.0 + math.exp(min(margin, MAX_EXP))), sphere.position - o.position, float(fit.radius))
    return out


def shared_cut_nats(problem: Problem, obj: Found, answer: Answer) -> float:
    """Nats the sensor model charges ``answer`` more than once for one occluder: :func:`repeated_cuts` of ``obj``'s
    box edges that the answer's prediction explains as cut (inside it by more than where the edge noise meets
    ``inward_floor``: each costs that floor), times the floor. Boxes the sensor model scores as a miss at worst
    (``miss_term``) paid no floor and are left out.

    The sensor model scores each view's cut as its own event. A leaf below a fruit cuts the bottom of its box in
    every view of an arc: one occluder seen from several places, so its cost is one surprise, not one per view; scored
    per view, a sphere cut so in five views pays five floors against a flattened model that shortens every box without
    a cut (why: docs/decisions/bayes-quality.md#one-occluder-one-cost).
    """
    poses, boxes = object_boxes(problem, obj)
    cam, model = problem.camera, problem.model
    pred, extra_sigma_px = predicted_boxes(problem, poses, answer[1], answer[0].solid)
    charged = box_scores(pred, boxes, model, cam.width, cam.height, extra_sigma_px) > model.miss_term
    z = edge_residuals(pred, boxes, model, cam.width, cam.height, extra_sigma_px)
    cut = (z > math.sqrt(2.0 * model.inward_floor)) & charged[:, None]
    return repeated_cuts(cut, poses[:, :3, :3]) * model.inward_floor


def repeated_cuts(cut: NDArray[np.bool_], R_base_optical: NDArray[np.float64]) -> int:
    """How many cut edges are one occluder's seen again: of the largest set of views whose box is cut on the same image
    side, that side facing the same way in the base frame (outward directions within :data:`SHARED_CUT_COS` of one
    of them), all views but one. One occluder per object; a second side cut too is another occluder, paid in full.

    Parameters
    ----------
    cut : ndarray, shape (K, 4), bool: the edges (``bbox_xyxy`` order) of each view's box that are cut
    R_base_optical : ndarray, shape (K, 3, 3): each view's camera rotation, optical to base frame

    Examples
    --------
    >>> import numpy as np
    >>> def yaw(deg):  # a camera turned about the base frame's z axis
    ...     c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    ...     return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    >>> bottom = np.array([[False, False, False, True]] * 3)
    >>> repeated_cuts(bottom, np.array([yaw(0), yaw(20), yaw(40)]))  # 20 degrees apart: one occluder
    2
    """
    views, sides = np.nonzero(cut)
    directions = np.einsum("kij,kj->ki", R_base_optical[views], SIDE_DIRECTIONS_OPTICAL[sides])
    largest = 0
    for i in range(len(views)):  # every cut edge as the occluder's reference: the largest group, whatever the order
        same = (sides == sides[i]) & (directions @ directions[i] >= SHARED_CUT_COS)
        largest = max(largest, len(set(views[same].tolist())))
    return max(largest - 1, 0)


def chi2_sf(x: float, dof: float) -> float:
    """The chi-square survival function P(X > x) on ``dof`` degrees of freedom (not necessarily whole), by the
    Wilson-Hilferty cube-root normal approximation: within 0.01 of the exact value from 3 dof on, which is all a
    reported p needs, and no 0.1 s import of scipy.special on every localisation.

    >>> round(chi2_sf(7.815, 3), 2)
    0.05
    """
    h = 2.0 / (9.0 * dof)
    z = ((max(x, 0.0) / dof) ** (1.0 / 3.0) - (1.0 - h)) / math.sqrt(h)
    return 0.5 * math.erfc(z / math.sqrt(2.0))


def unexplained_boxes(problem: Problem, objects: tuple[Found, ...], variance_factor: float) -> list[tuple[int, int]]:
    """The boxes ``(view, box)`` (session view index, detection index) that no object holds and that no object explains
    as its own box seen with the session's noise: every edge not on the image border within ``gate_sigmas`` of the
    object's predicted box, the sensor model's edge noise scaled by ``sqrt(variance_factor)`` (at least 1).

    Under noise beyond the sensor model's, a fruit's box may fall outside the search's gate and stay free beside its
    object; a box of a fruit no object stands for (or of a mistake) lies away from every prediction."""
    held = {(v, j) for o in objects for v, j in o.associations.items()}
    free = [(vd, j) for vd in problem.views for j in range(len(vd.boxes)) if (vd.index, j) not in held]
    if not free or not objects:
        return [(vd.index, j) for vd, j in free]
    cam, model = problem.camera, problem.model
    centres = np.array([o.position for o in objects])
    semis = np.array([o.semi_axes if o.semi_axes is not None else [o.radius] * 3 for o in objects], dtype=float)
    rots = np.array(
        [rotation_from_quaternion_xyzw(o.quaternion_xyzw) if o.quaternion_xyzw is not None else np.eye(3) for o in objects]
    )
    scale = math.sqrt(max(variance_factor, 1.0))
    out, predicted = [], {}
    for vd, j in free:
        if vd.index not in predicted:
            T_base_optical = np.linalg.inv(vd.T_optical_base)
            with np.errstate(invalid="ignore", divide="ignore"):
                predicted[vd.index] = ellipsoid_bbox(cam, T_base_optical[None], centres, semis, rots, clip=False)
        pred = predicted[vd.index]
        box = vd.boxes[j]
        z = (box[None] - pred) / (scale * box_edge_sigma_px(model, pred))
        seen = ~censored_edges(box, cam.width, cam.height, model.border_px)
        with np.errstate(invalid="ignore"):
            near = np.all(np.isfinite(pred), axis=1) & np.all(np.abs(z[:, seen]) <= model.gate_sigmas, axis=1)
        if not near.any():
            out.append((vd.index, j))
    return out


def _covariance(fit: _Fit, S: NDArray[np.float64], scale: float) -> tuple[NDArray[np.float64] | None, str | None]:
    """The centre's sandwich covariance (3, 3), m^2, times ``scale``, or None and the reason."""
    J = fit.J
    A = J.T @ J
    try:
        Ainv = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        return None, "the boxes do not determine the position (singular normal matrix)"
    if not np.all(np.isfinite(Ainv)) or np.linalg.cond(A) > 1e14:
        return None, "the boxes do not determine the position (the views see it from one place: depth unobservable)"
    C = (Ainv @ (J.T @ S @ J) @ Ainv)[:3, :3]
    C = 0.5 * (C + C.T)
    w = np.linalg.eigvalsh(C)
    if not (np.all(np.isfinite(w)) and w[0] > 0 and scale > 0):
        return None, "the boxes do not determine the position (covariance not positive definite)"
    if math.sqrt(w[-1]) > UNDETERMINED_SHARE * fit.distance:  # the geometry's, before the object's own factor
        return None, (
            f"the boxes do not determine the position: its standard deviation ({math.sqrt(w[-1]):.2g} m) exceeds half its "
            f"distance to the cameras ({fit.distance:.2g} m); views from more places determine the depth"
        )
    return C * scale, None


def causes_of(quality: Quality) -> tuple[Cause, ...]:
    """The named causes of the module docstring that the session's quality shows."""
    out = []
    if quality.dof >= SCATTER_MIN_DOF and quality.variance_factor > SCATTER_FACTOR:
        times = math.sqrt(quality.variance_factor)
        out.append(
            Cause(
                "scatter",
                f"scatter: the boxes sit {times:.1f} times the sensor model's edge noise from the fitted fruit "
                f"(variance factor {quality.variance_factor:.1f} on {quality.dof} degrees of freedom); check the poses, the "
                "camera intrinsics and the box format, or state the detector's edge noise (--alpha)",
                "suspect",
                details={"variance_factor": quality.variance_factor, "dof": quality.dof},
            )
        )
    if quality.unexplained >= UNEXPLAINED_MIN and quality.unexplained >= UNEXPLAINED_SHARE * quality.n_boxes:
        out.append(
            Cause(
                "unexplained_boxes",
                f"unexplained boxes: {quality.unexplained} of {quality.n_boxes} boxes are held and explained by no object; "
                "check that the views look at the same fruit, the poses and the box format (pixels x1, y1, x2, y2)",
                "suspect",
                details={"unexplained": quality.unexplained, "n_boxes": quality.n_boxes},
            )
        )
    return tuple(out)


def run(problem: Problem, state: State) -> State:
    """The pass: :func:`assess` the objects, their covariances replaced by the honest ones, the quality and its causes
    added to the state."""
    quality, objects = assess(problem, state.objects)
    return replace(state, objects=objects, quality=quality, causes=state.causes + causes_of(quality))
