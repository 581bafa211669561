"""The session's box-edge noise: the sensor model's ``alpha`` raised to what the boxes show.

The sensor model says how far a detector's box edges scatter (``alpha * size + sigma0_px``, :mod:`.sensor`; ``alpha``
5 % of the box by default). Everything downstream weighs the boxes by it: the search's association gate, the
refinement's weights, the shape fits' information criterion and the covariance's first factor. A detector whose edges
scatter more than that (10 % of the box) is weighed as if it were better than it is: its boxes of one round fruit can
prefer an elongated solid, boxes of a fruit fall outside the gate and are left to no object, and the covariance,
although the session's variance factor scales it, rests on fits that chose their shape and boxes under the wrong noise.

:func:`adapt` looks at the first estimate's two session variance factors (:mod:`.quality`: the boxes' residuals against
their fitted solids, over what the sensor model predicts for them). Where the clipped chi-square's factor exceeds
:data:`ADAPT_FACTOR` (the edges scatter 1.6 times the model's noise) and the median residual's factor exceeds
:data:`ADAPT_ROBUST_FACTOR` (the typical edge scatters beyond the model, not only a minority of boxes cut by leaves or
taken from a neighbour), on at least :data:`ADAPT_MIN_DOF` degrees of freedom, the detector's edge noise is larger than
stated, and the session is localised again with ``alpha * sqrt(factor)`` (the clipped factor, capped at
:data:`MAX_FACTOR`). The second estimate is the answer, and ``quality.edge_noise`` reports what was done.

Only the ``alpha * size`` part of the edge noise is raised: where the pixel floor or a stated pose noise dominates (small,
far boxes), the second estimate's noise still falls short of the boxes'. The second estimate's ``quality`` is under the
raised noise (its variance factor near 1), and the result's ``config`` keeps the stated ``alpha``.

Not where the first estimate is already flagged: a cause it names (a view that disagrees, an image size that is not the
calibration's, scatter beyond :data:`.quality.SCATTER_FACTOR`...), a warning (views whose boxes sit off together), or
boxes left that no object explains
(``--strict``'s completeness check, :func:`monovisual3d.completeness.incomplete_reasons`). The scatter is then the
mistake's, not the detector's, and a looser model would only blur what the warning says: another view's boxes that
no object explained under the stated noise are taken into objects under the raised one.

Why these numbers (and the measurements): docs/decisions/bayes-quality.md#the-sessions-edge-noise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from .problem import Problem
from .quality import SCATTER_FACTOR, SCATTER_MIN_DOF

#: The first estimate's (clipped) variance factor above which the session is localised again with a larger ``alpha``:
#: edge noise 1.6 times the model's. Under the model the factor is 1 within its chance spread (about 0.2 on 50-100
#: degrees of freedom); boxes cut by leaves raise it without a noisier detector, hence the second test.
ADAPT_FACTOR = 2.5
#: ...and the median residual's factor (``quality.robust_factor``) above which: the typical edge scatters beyond the
#: model (1.18 times its noise), not only a minority of edges cut by leaves, which leave the median near 1.
ADAPT_ROBUST_FACTOR = 1.4
#: Degrees of freedom the variance factor must rest on (fewer: no evidence about the detector's noise): those the
#: ``scatter`` cause needs.
ADAPT_MIN_DOF = SCATTER_MIN_DOF
#: The most the variance factor raises ``alpha`` by is ``sqrt(MAX_FACTOR)``: beyond it (edge noise four times the
#: model's) the scatter is a mistake to name (the ``scatter`` cause, which then stops the second estimate), not a
#: detector to model; a guard for a caller of :func:`adapted_alpha` without that cause.
MAX_FACTOR = SCATTER_FACTOR


def adapted_alpha(alpha: float, quality: dict[str, Any]) -> float | None:
    """The edge noise (fraction of the box size) for a second estimate, or None where the first one's ``quality``
    (:meth:`.state.Quality.to_dict`) shows no scatter beyond ``alpha``.

    >>> adapted_alpha(0.05, {"variance_factor": 4.0, "robust_factor": 2.0, "dof": 60})
    0.1
    >>> adapted_alpha(0.05, {"variance_factor": 4.0, "robust_factor": 1.1, "dof": 60}) is None  # a few boxes cut
    True
    """
    factor, robust, dof = quality.get("variance_factor"), quality.get("robust_factor"), quality.get("dof", 0)
    if alpha <= 0:  # no size-proportional noise stated: nothing to scale
        return None
    if factor is None or robust is None or not (math.isfinite(factor) and math.isfinite(robust)):
        return None
    if factor <= ADAPT_FACTOR or robust <= ADAPT_ROBUST_FACTOR or dof < ADAPT_MIN_DOF:
        return None
    return alpha * math.sqrt(min(factor, MAX_FACTOR))


def adapt(
    problem: Problem, first: Any, estimate: Callable[[Problem], Any], flagged: Callable[[Any], bool] | None = None
) -> tuple[Problem, Any]:
    """The problem and estimate (:class:`.pipeline.Estimate`, not imported here: the front end passes the pipeline in,
    which keeps the chain of imports short) with the edge noise the boxes show (see the module docstring): ``first``
    and ``problem`` unchanged where the config states the noise (``edge_noise='stated'``), the boxes scatter as stated,
    or the first estimate names a cause or is ``flagged`` (a test of the estimate, asked only where it decides); else
    ``estimate``
    (:func:`.pipeline.estimate`) run again with ``alpha`` raised, and ``quality["edge_noise"]`` saying so (the first
    estimate where the second finds no object: the raised noise lowers every score, and an empty answer is not the
    better one)."""
    config = problem.config
    if config.edge_noise != "auto" or not first.objects or first.causes:
        return problem, first
    stated = config.sensor.alpha
    alpha = adapted_alpha(stated, first.quality)
    if alpha is None or (flagged is not None and flagged(first)):
        return problem, first
    original, config = problem, replace(config, sensor=replace(config.sensor, alpha=alpha))
    problem = replace(problem, config=config, model=config.sensor)
    second = estimate(problem)
    if not second.objects:
        return original, first
    report = {
        "alpha": alpha,
        "stated_alpha": stated,
        "first_variance_factor": first.quality["variance_factor"],
        "first_estimate_s": sum(first.timing_s.values()),
        "note": (
            f"edge noise: the boxes scatter {math.sqrt(first.quality['variance_factor']):.1f} times the sensor model's "
            f"(alpha {stated:g}); localised again with alpha {alpha:.3g} (--edge-noise stated keeps it)"
        ),
    }
    return problem, replace(second, quality={**second.quality, "edge_noise": report})
