"""The shape stage: each object as a sphere, spheroid or ellipsoid (``BayesConfig.shape``).

The search, extraction and association run with spheres and upright or lying spheroids
(``BayesConfig.elongations``, ``BayesConfig.lying_yaws``), so a tall or wide box is found and
associated as what it is. This stage first refits each object, the edges a nearer object cuts censored
(:func:`occlusion_refit`; the extraction's refinement took them as full edges) and, for a sphere, an edge inside its
prediction taken as a possible cut by an occluder the search does not see (a leaf: :func:`one_sided_refit`), then refines the
shape: it fits each object's associated boxes with the shape
model (:func:`monovisual3d.geometry.fit.fit_shape_by_bic`, robust; an edge on the image border or one a nearer
object hides counts one-sided: the object reaches at least that far):

- ``sphere``: the sphere estimate is kept (the shape fields are filled in);
- ``spheroid`` / ``ellipsoid``: that model is fitted;
- ``auto`` (default): round-looking objects stay spheres without a fit; an
  object whose boxes are elongated the same way in every view (an upright object) is
  fitted as sphere, spheroid and (with at least :data:`MIN_VIEWS_FOR_ELLIPSOID`
  views) ellipsoid, and the model with the lowest BIC is kept. An object whose
  boxes are elongated both ways (:func:`looks_round`), or wider than its sphere's
  in every view, is also fitted with the ellipsoid from :data:`MIN_VIEWS_FOR_LYING`
  views, and that fit replaces its sphere (or its first fit) only when the sensor
  model prefers it (:func:`beats`). An object taller than its sphere in every view
  stands upright, round in plan, and keeps the first fit. An object larger than
  :data:`LARGE_RADIUS_M` whose boxes look round is fitted with every model, the
  solids included; one elongated both ways is offered the solids with the lying
  fits (:func:`fit_shape`).

With ``BayesConfig.solids``, an object elongated one way is also fitted as an upright cylinder (and, with
:data:`MIN_VIEWS_FOR_CUBOID` views, a cuboid with a yaw): the exact boxes of a can, a bottle or a box
(:mod:`monovisual3d.geometry.solids`). The ellipsoid models predict a container's boxes wrong where its top rim
sticks out, seen from above, and that biases its centre down by a few millimetres
(why: docs/decisions/bayes-shapes.md#solids).
The solid is kept only when the boxes clearly prefer it to the best ellipsoid model, with the edge noise
estimated from the fits (:func:`.solid_choice.solid_evidence`, :data:`.solid_choice.SOLID_EVIDENCE_NATS`): under noisy boxes the two are
equally good and fruit stay ellipsoids. A solid reports its centre as the position, its radius or half-sides as
``semi_axes`` with the shape of the ellipsoid of the same semi-axes (``spheroid``, ``ellipsoid``), and
``extra["solid"]`` (``cylinder``, ``cuboid``).
It is on by default (``--no-solids`` turns it off): on the real Aldoma set (``monovisual3d bench real``) the one
object it changes, a bottle (its neck narrows like an ellipsoid's top), moves 3 mm further from its ground-truth
ellipsoid's centre (docs/real.md).

Lying objects (a can, a box or a cucumber on its side: the long axis horizontal) are
the ``ellipsoid`` model (two horizontal semi-axes and a yaw). Their boxes are wide
where the camera sees them broadside and tall where it looks along the long axis
from above, so the sign of their elongation changes with the view; an upright
object's does not. An occluded sphere's boxes also change their aspect from view
to view, at random: a box cut by a leaf is wide or tall. The two are told apart by
the sensor model, which already explains a cut box (an edge inside the prediction
costs at most ``inward_floor``): the fit must beat the sphere by the sensor model's
Bayesian information criterion.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ...geometry.fit import fit_parameters
from ...geometry.solids import SOLIDS
from .aspects import (
    ROUNDNESS_THRESHOLD,
    as_sphere,
    aspect_deviations,
    consistently_elongated,
    elongated_one_way,
    looks_round,
    possibly_cut,
    round_aspects,
    sticks_out,
    strongly_elongated,
)
from .fits import (
    Answer,
    beats,
    boxes_as_seen,
    every_shape,
    lowest_bic_fit,
    lying_shapes,
    sensor_score,
    sphere_answer,
    upright_shapes,
    upright_solids,
)
from .occlusion import occlusion_flags, predicted_views
from .problem import Problem
from .refine import MIN_VIEWS_ONE_SIDED, Observation, refine_sphere, refine_spheroid
from .scoring import spheroid_axis
from .state import Found, State

#: Radius (metres: the search's sphere's, or its spheroid's horizontal semi-axis, ``Found.radius``) beyond
#: which ``auto`` fits an object with every model, the solids included, however round its boxes look. A wrong shape
#: moves the centre by a fraction of the object's size: a fruit's few millimetres, a large object's tens. A flat 200 x 160 x 30 mm tray seen from 55 degrees above has near-square boxes;
#: kept the search's sphere of 110-125 mm radius, it came out 20-57 mm low, where the cuboid fits its boxes to 2-3 px
#: RMS (the sphere 13-22 px) and lands 2-6 mm off. Fruit (the paper's tomatoes, 20-40 mm) never pay for the fits.
LARGE_RADIUS_M = 0.06

# ``BayesConfig.tuning.cut_inward_floor`` (1.5 nats) is the inward floor of the loss of the final sphere refit
# (:func:`one_sided_refit`), the outward one staying the sensor model's ``outward_floor`` (6): the per-edge likelihood is
# a mixture of the Gaussian edge noise and a flat tail ``exp(-floor)`` of its peak, an occluder's cut inward. Occlusion
# only shrinks a box, so an edge inside the prediction may be a cut and costs less than one outside; a low floor lets a
# cut edge go, at the price of weighing inward noise edges less where nothing is occluded
# (why: docs/decisions/bayes-occlusion.md#cut_inward_floor).


def fit_shape(
    problem: Problem,
    obj: Found,
    cut: frozenset[int] = frozenset(),
    censored: NDArray[np.bool_] | None = None,
    hidden_to: NDArray[np.float64] | None = None,
) -> Found:
    """One object through the shape stage (module docstring) under ``BayesConfig.shape``; ``cut``: the session indices
    of the views where a nearer object cuts its box (:func:`.occlusion.occlusion_flags`). With ``auto``:

    - round boxes (:func:`round_aspects`) keep the sphere, unless one is elongated and an edge sticks out of the
      sphere's prediction (:func:`sticks_out`: no cut makes a box larger, even where a nearer object is predicted to
      cut it), or one is elongated far beyond box noise (:func:`strongly_elongated`: a flat tray);
    - elongated both ways only through the boxes a nearer object cuts, no edge sticking out: a sphere (cuts made it so);
    - elongated one way and cut (by a nearer object, or :func:`possibly_cut`: a leaf): the fit only where it
      :func:`beats` the sphere, which scores a cut box as occluded (neighbours in a dense row cut a fruit's boxes to
      tall slivers that a small near spheroid fits), unless two or more uncut boxes elongated alike show the shape
      (:func:`consistently_elongated`: a cut changes the boxes it cuts, a shape all of them;
      why: docs/decisions/bayes-shapes.md#uncut-boxes-elongated-alike);
    - taller in every view: upright, round in plan, the first fit kept; wider in every view, or elongated both ways:
      the lying fits too, kept where they :func:`beats` the first answer;
    - larger than :data:`LARGE_RADIUS_M`: every model, the solids included, even for round boxes (a wrong shape moves
      a large object's centre by tens of millimetres), and a solid its evidence chooses."""
    cfg = problem.config
    n_views = len(obj.associations)
    if cfg.shape == "sphere" or n_views < 2:
        return as_sphere(obj)
    if cfg.shape != "auto":
        fit = lowest_bic_fit(problem, obj, (cfg.shape,), censored, hidden_to=hidden_to)
        return as_sphere(obj) if fit is None else fit[0][0]
    deviations = aspect_deviations(problem, obj)

    def outgrown() -> bool:  # asked only where it decides: a box prediction per object
        return bool(np.any(np.abs(deviations) > ROUNDNESS_THRESHOLD)) and sticks_out(problem, obj)

    large = float(obj.radius) > LARGE_RADIUS_M  # type: ignore[arg-type]  # set for every object of the search
    if round_aspects(deviations) and not outgrown() and not strongly_elongated(deviations):
        return _large_round_fit(problem, obj, censored, hidden_to) if large else as_sphere(obj)
    solids_fitted = False  # the upright solids, where the first fit already weighed them
    if elongated_one_way(deviations):
        upright = upright_shapes(n_views, cfg.solids)
        solids_fitted = cfg.solids
        fit = lowest_bic_fit(problem, obj, upright, censored, hidden_to=hidden_to)
        uncut = aspect_deviations(problem, obj, cut) if cut else deviations  # the boxes no nearer object cuts
        shows_shape = elongated_one_way(uncut) and consistently_elongated(uncut)
        cut_here = (cut and not shows_shape) or (possibly_cut(problem, obj) and not consistently_elongated(deviations))
        if fit is not None and cut_here and not beats(problem, obj, fit[0], sphere_answer(obj), fit[1], hidden_to):
            return as_sphere(obj)  # its boxes are cut, which the sensor model explains as well as the fit does
        if fit is None or np.all(deviations > 0) or set(lying_shapes(n_views)) <= set(upright):
            return as_sphere(obj) if fit is None else fit[0][0]  # taller in every view: upright, round in plan
        answer = fit[0]  # wider in every view: lying (seen from one side) or flat
    else:  # elongated both ways (lying, or a sphere whose boxes are cut), or one box only but outgrown or strongly
        answer = sphere_answer(obj)
        uncut = aspect_deviations(problem, obj, cut) if cut else deviations
        both_ways = np.any(uncut > ROUNDNESS_THRESHOLD) and np.any(uncut < -ROUNDNESS_THRESHOLD)
        if cut and not both_ways and not outgrown():
            return answer[0]  # the boxes nearer objects do not cut are not elongated both ways: the cuts made it look so
    solid = answer[0].solid
    solids = upright_solids(n_views) if large and cfg.solids and not solids_fitted else ((solid,) if solid else ())
    return _better_fit(problem, obj, answer, lying_shapes(n_views) + solids, censored, hidden_to)


def _large_round_fit(
    problem: Problem, obj: Found, censored: NDArray[np.bool_] | None, hidden_to: NDArray[np.float64] | None
) -> Found:
    """A large object (:data:`LARGE_RADIUS_M`) whose boxes look round, fitted with every model (:func:`_better_fit`)."""
    shapes = every_shape(len(obj.associations), problem.config.solids)
    return _better_fit(problem, obj, sphere_answer(obj), shapes, censored, hidden_to)


def _better_fit(
    problem: Problem,
    obj: Found,
    answer: Answer,
    shapes: tuple[str, ...],
    censored: NDArray[np.bool_] | None,
    hidden_to: NDArray[np.float64] | None,
) -> Found:
    """``answer`` or the lowest-BIC fit of ``shapes`` (:func:`lowest_bic_fit`): a solid won by its evidence (a flat tray:
    :func:`.solid_choice.solid_if_clear`) is taken unless ``answer`` is a solid already; an ellipsoid model (a lying
    object) only where it :func:`beats` ``answer``."""
    if _ellipsoid_cannot_change(problem, obj, answer, shapes, censored, hidden_to):
        return answer[0]
    new = lowest_bic_fit(problem, obj, shapes, censored, hidden_to=hidden_to)
    if new is None:
        return answer[0]
    if new[0][0].solid:
        return answer[0] if answer[0].solid else new[0][0]
    return new[0][0] if beats(problem, obj, new[0], answer, new[1], hidden_to) else answer[0]


def _ellipsoid_cannot_change(
    problem: Problem,
    obj: Found,
    answer: Answer,
    shapes: tuple[str, ...],
    censored: NDArray[np.bool_] | None,
    hidden_to: NDArray[np.float64] | None,
) -> bool:
    """Whether :func:`_better_fit` keeps ``answer`` whatever the three-axis ellipsoid's fit (the costliest of its
    models: a dense row's cut fruit pay for it), so that it need not be fitted: the lowest-BIC fit of the other models
    does not :func:`beats` ``answer``, and no ellipsoid could. Its sensor score is at most every box's best,
    ``match_bonus`` (each edge's log-likelihood is at most 0, a miss scores less), so it beats ``answer`` only where
    that ceiling exceeds ``answer``'s score by more than its extra parameters' ``ln(edges) / 2`` nats each; were the
    ellipsoid the lowest BIC, :func:`_better_fit` would keep ``answer`` then, and were it not, the other models' fit
    is the one it weighs. Only without solids among ``shapes`` (their choice follows other rules)."""
    if "ellipsoid" not in shapes or any(m in SOLIDS for m in shapes):
        return False
    rest = lowest_bic_fit(problem, obj, tuple(m for m in shapes if m != "ellipsoid"), censored, hidden_to=hidden_to)
    if rest is None or rest[0][0].solid or beats(problem, obj, rest[0], answer, rest[1], hidden_to):
        return False
    poses, boxes = boxes_as_seen(problem, obj, answer, hidden_to)
    ceiling = len(boxes) * max(problem.model.match_bonus, problem.model.miss_term)
    gain = ceiling - sensor_score(problem, poses, boxes, answer[1], answer[0].solid)
    n_params = len(fit_parameters("ellipsoid", free_orientation=problem.config.free_orientation))
    return gain + ELLIPSOID_BOUND_SLACK_NATS <= 0.5 * (n_params - answer[2]) * math.log(max(rest[1], 1))


#: Nats added to the ellipsoid's best possible gain (:func:`_ellipsoid_cannot_change`) against the rounding of a sum of
#: box scores: a margin, far below any score difference that decides.
ELLIPSOID_BOUND_SLACK_NATS = 1e-9


def occlusion_refit(
    problem: Problem, objects: list[Found], flags: list[tuple[list[Observation], frozenset[int]] | None] | None = None
) -> list[Found]:
    """Refit each object whose boxes a nearer object cuts, those edges censored (only outward residuals count).

    The refinement of the extraction takes an occluded box as a full one; its robust loss stops an edge
    cut by more than about three sigmas from pulling, but a smaller cut biases the fit. Here the other
    objects' predicted boxes say which edges a nearer object cuts (:func:`.occlusion.occlusion_flags`, computed here when
    ``flags`` is None), and the object is refitted from its estimate with those edges censored, as edges on the
    image border are. Objects refined jointly with the poses (``pose_corrected``) keep their joint solution. Every
    other sphere fitted on boxes (no masks) is refitted so, cut or not, with the one-sided loss of
    :func:`one_sided_refit` (a leaf's cut is no object's).
    """
    flags = occlusion_flags(problem, objects) if flags is None else flags
    out = []
    for o, f in zip(objects, flags):
        one_sided = f is not None and len(f[0]) >= MIN_VIEWS_ONE_SIDED and o.semi_up is None
        if one_sided and problem.config.tuning.one_sided_refit and not problem.config.use_masks:
            out.append(one_sided_refit(problem, o, f[0]))
        else:
            out.append(o if f is None or not f[1] else _refit(problem, o, f[0]))
    return out


def one_sided_refit(problem: Problem, o: Found, obs: list[Observation]) -> Found:
    """The sphere ``o`` refitted on its box observations ``obs`` (edges a nearer object cuts censored, from
    :func:`.occlusion.occlusion_flags`) with a loss that tells a cut from noise by its side: an edge inside the prediction costs
    at most ``BayesConfig.cut_inward_floor`` nats, one outside at most the sensor model's ``outward_floor``
    (:func:`.refine.one_sided_residuals`).

    Occlusion (a leaf, an undetected object) only shrinks a box; the refinement of the extraction scores inward and
    outward misses alike (``inward_floor``, 3 nats, both sides), so an edge a leaf cuts by two or three sigmas still
    pulls the sphere inward. ``o`` itself when the fit fails or leaves the radius range.
    """
    return _refit(problem, o, obs, (problem.config.tuning.cut_inward_floor, problem.model.outward_floor))


def _refit(problem: Problem, o: Found, obs: list[Observation], floors: tuple[float, float] | None = None) -> Found:
    """``o`` refitted on ``obs`` from its estimate; ``o`` itself when the fit fails or leaves the radius range.
    ``floors``: see :func:`.refine.refine_sphere` (spheres only)."""
    cfg, r = problem.config, float(o.radius)  # type: ignore[arg-type]
    b = o.semi_up
    if b is None:
        fit = refine_sphere(problem.camera, obs, o.position, r, problem.model, use_masks=cfg.use_masks, floors=floors)
    else:
        fit = refine_spheroid(problem.camera, obs, o.position, r, float(b), problem.model, spheroid_axis(problem, o.axis))
    sizes = [fit.radius] + ([] if fit.semi_up is None else [fit.semi_up])
    lo, hi = cfg.fit_radius_range
    if not (fit.success and all(lo <= s <= hi for s in sizes)):
        return o
    learned = {**o.learned(), "radius_std": fit.radius_std if np.isfinite(fit.radius_std) else None}
    if fit.semi_up is not None:
        learned["semi_up"] = float(fit.semi_up)
    cov = fit.covariance if np.all(np.isfinite(fit.covariance)) else None
    return Found(fit.centre, o.score, float(fit.radius), cov, o.associations, o.n_cells, **learned)


def shape_stage(problem: Problem, objects: list[Found]) -> list[Found]:
    """Every object through :func:`occlusion_refit`, then :func:`fit_shape` (an object whose boxes look elongated both
    ways only because nearer objects cut them stays a sphere).

    The shape fits leave out each box edge along which a nearer object's predicted box covers the whole side
    (:func:`.occlusion.covered_sides`; nearer objects whose prediction can be trusted only: found as spheroids, or round): two
    containers side by side seen from their height, the farther box ends where the nearer begins, and taken at face
    value that edge puts the farther container off (why: docs/decisions/bayes-occlusion.md#covered_sides).
    Behind an elongated occluder (straight-sided) such an edge is left out only where it ends at the occluder's box
    edge, as a box of the visible part does (:func:`.occlusion.ends_at_occluder`): an edge well inside is an amodal
    box's own edge, and without it a sphere of the containers' height can take the farther container's place
    (why: docs/decisions/bayes-occlusion.md#ends_at_occluder). The sphere refit keeps the looser test of one extreme
    point (:func:`.occlusion.occluded_edges`); in the shape fits a tall object's edge stays while any part of its side
    shows (a farther container's top above the nearer one): the looser test there costs box-shaped containers seen
    from above. A left-out edge is hidden no further than the far side of the nearer box that hides it
    (:func:`.occlusion.occlusion_flags`), in the fits and in
    :func:`beats`."""
    predicted = predicted_views(problem, objects)
    flags = occlusion_flags(problem, objects, predicted=predicted)
    refitted = occlusion_refit(problem, objects, flags)
    trusted = [o.semi_up is not None or looks_round(problem, o) for o in objects]
    shape_flags = occlusion_flags(problem, objects, trusted, whole_sides=True, predicted=predicted)
    out = []
    for o, f in zip(refitted, shape_flags):
        censored = None if f is None else np.array([ob.censored for ob in f[0]], dtype=bool).reshape(-1, 4)
        hidden_to = None if f is None else np.array([ob.hidden_to for ob in f[0]], dtype=float).reshape(-1, 4)
        if censored is not None and len(censored) != len(o.associations):
            censored = hidden_to = None  # the refit changed the association: the flags no longer apply
        out.append(fit_shape(problem, o, frozenset() if f is None else f[1], censored, hidden_to))
    return out


def run(problem: Problem, state: State) -> State:
    """The pass: every object through :func:`shape_stage`."""
    return state.with_objects(shape_stage(problem, list(state.objects)))
