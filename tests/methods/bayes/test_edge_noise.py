"""The session's edge noise (:mod:`monovisual3d.methods.bayes.edge_noise`): ``alpha`` raised where the boxes scatter
beyond it, the first estimate's causes kept, and the option in every front end."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.api import localize
from monovisual3d.batch.work import quality_columns
from monovisual3d.bench.trust_cases import make_case
from monovisual3d.errors import InputError
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes.edge_noise import (
    ADAPT_FACTOR,
    ADAPT_MIN_DOF,
    ADAPT_ROBUST_FACTOR,
    MAX_FACTOR,
    adapt,
    adapted_alpha,
)
from monovisual3d.methods.bayes.pipeline import Estimate
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.result import DetectedObject
from monovisual3d.verdict import Cause


def test_adapted_alpha_scales_by_the_root_of_the_factor_only_beyond_both_thresholds() -> None:
    def q(factor: float, robust: float = 2.0, dof: int = 60) -> dict[str, float]:
        return {"variance_factor": factor, "robust_factor": robust, "dof": dof}

    assert adapted_alpha(0.05, q(ADAPT_FACTOR)) is None
    assert adapted_alpha(0.05, q(9.0, ADAPT_ROBUST_FACTOR)) is None  # the median edge as the model says: a few cut
    assert adapted_alpha(0.05, q(9.0, dof=ADAPT_MIN_DOF - 1)) is None
    assert adapted_alpha(0.05, {}) is None
    assert adapted_alpha(0.0, q(9.0)) is None  # noise stated as a pixel floor only: nothing to scale
    assert adapted_alpha(0.05, q(float("nan"))) is None
    assert_allclose(adapted_alpha(0.05, q(9.0)), 0.15)
    assert_allclose(adapted_alpha(0.04, q(100.0)), 0.04 * np.sqrt(MAX_FACTOR))


def _problem(edge_noise: str = "auto"):  # noqa: ANN202 - a Problem
    case = make_case("paper", 0, 0.05)
    return build_problem(case.session.camera, BayesConfig(edge_noise=edge_noise), case.session.views)


SCATTER = Cause("scatter", "scatter: the boxes sit far from the fitted fruit", "suspect")


def _first(factor: float, causes: tuple[Cause, ...] = ()) -> Estimate:
    obj = DetectedObject(position=np.zeros(3), score=20.0, radius=0.04)
    quality = {"variance_factor": factor, "robust_factor": 2.0, "dof": 60}
    return Estimate([obj], quality=quality, causes=causes, timing_s={"search": 1.0})


def test_adapt_runs_again_with_the_raised_alpha() -> None:
    seen = []

    def second(problem):  # noqa: ANN001, ANN202 - the pipeline's signature
        seen.append(problem)
        return Estimate([obj], quality={"variance_factor": 1.0, "dof": 60}, timing_s={"search": 2.0})

    obj = DetectedObject(position=np.ones(3), score=12.0, radius=0.04)

    problem, out = adapt(_problem(), _first(9.0), second)
    assert len(seen) == 1 and seen[0] is problem
    assert_allclose([problem.model.alpha, problem.config.sensor.alpha], [0.15, 0.15])
    report = out.quality["edge_noise"]
    assert report.pop("note").startswith("edge noise: the boxes scatter 3.0 times the sensor model's (alpha 0.05)")
    assert report == {"alpha": pytest.approx(0.15), "stated_alpha": 0.05, "first_variance_factor": 9.0, "first_estimate_s": 1.0}
    assert out.timing_s == {"search": 2.0}


def test_adapt_keeps_the_first_estimate_where_the_second_finds_nothing() -> None:
    problem, first = _problem(), _first(9.0)
    assert adapt(problem, first, lambda p: Estimate([], quality={"variance_factor": 1.0, "dof": 0})) == (problem, first)


def test_adapt_leaves_the_estimate_where_the_noise_is_as_stated_stated_by_the_user_or_already_flagged() -> None:
    def never(problem):  # noqa: ANN001, ANN202
        raise AssertionError("estimated again")

    problem = _problem()
    for first in (_first(1.2), _first(9.0, (SCATTER,))):
        assert adapt(problem, first, never) == (problem, first)
    first = _first(9.0)
    assert adapt(problem, first, never, flagged=lambda estimate: estimate is first) == (problem, first)
    stated = _problem("stated")
    assert "edge_noise" not in adapt(stated, _first(9.0), never)[1].quality


def test_edge_noise_option_is_checked() -> None:
    with pytest.raises(InputError, match="edge_noise: got 'fixed'"):
        BayesConfig(edge_noise="fixed")


def test_noisy_detector_session_reports_the_edge_noise_it_used() -> None:
    """Boxes 10 % of their size off where the model says 5 %: the second estimate's variance factor is near 1 and the
    report names the alpha used; told ``stated``, the same session keeps 5 % and a factor well above 1."""
    case = make_case("greenhouse", 14, 0.10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        auto = localize(case.session)
        stated = localize(case.session, edge_noise="stated")
    report = auto.quality["edge_noise"]
    assert report["stated_alpha"] == 0.05 and 0.08 < report["alpha"] < 0.2
    assert report["first_variance_factor"] == pytest.approx(stated.quality["variance_factor"])
    assert stated.quality["variance_factor"] > ADAPT_FACTOR and "edge_noise" not in stated.quality
    assert stated.quality["robust_factor"] > ADAPT_ROBUST_FACTOR
    assert auto.quality["variance_factor"] < 2.0
    assert quality_columns(auto)["edge_noise_alpha"] == report["alpha"]  # batch's sessions table
