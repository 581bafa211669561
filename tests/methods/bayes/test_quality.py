"""The consistency model and the honest covariance (:mod:`monovisual3d.methods.bayes.quality`), and the verdict as
every front end carries it (issue 53)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from monovisual3d.api import localize
from monovisual3d.bench.trust_cases import TrustCase, make_case
from monovisual3d.bench.trust_runs import is_positive_definite
from monovisual3d.errors import InputWarning
from monovisual3d.methods.bayes import BayesConfig, BayesLocalizer
from monovisual3d.methods.bayes.problem import Problem
from monovisual3d.methods.bayes.quality import (
    Quality,
    assess,
    causes_of,
    cut_spheres,
    object_factor,
    repeated_cuts,
    shared_cut_nats,
)
from monovisual3d.methods.bayes.state import Found, State
from monovisual3d.metrics import match
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import default_camera, paper_scene, scene_target
from monovisual3d.sim.simulate import simulate
from monovisual3d.sim.viewpoints import paper_poses

#: chi-square(3)'s 95 % quantile: a calibrated covariance's NEES lies beyond it for 5 % of fruit.
NEES_95 = 7.815


def _quiet_localize(session):  # noqa: ANN001, ANN202 - a Session
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return localize(session)


def _nees(result, centres: np.ndarray) -> list[float]:  # noqa: ANN001 - a Result
    ei, ti = match(result.positions, centres)
    out = []
    for e, t in zip(ei, ti):
        err = result.positions[e] - centres[t]
        C = result.objects[e].covariance
        if np.linalg.norm(err) < 0.02 and C is not None:
            out.append(float(err @ np.linalg.solve(C, err)))
    return out


def test_every_covariance_is_positive_definite_with_its_residuals_reported() -> None:
    case = make_case("paper", 0, 0.05)
    result = _quiet_localize(case.session)
    q = result.quality
    assert q["verdict"] == "ok" and q["causes"] == []
    assert len(q["objects"]) == len(result.objects) > 0
    for obj, oq in zip(result.objects, q["objects"]):
        assert obj.covariance is not None and is_positive_definite(obj.covariance)
        assert oq["dof"] > 0 and oq["residual_chi2"] >= 0 and oq["variance_factor"] > 0
    assert {v["view"] for v in q["views"]} == set(range(len(case.session.views)))
    assert all(0 <= v["p"] <= 1 and v["consistency"] > 0 for v in q["views"])


def test_all_views_at_one_pose_give_no_covariance_with_the_reason() -> None:
    scene, camera = paper_scene(), default_camera()
    pose = paper_poses(scene_target(scene))[0]
    session, _ = simulate(scene, camera, np.stack([pose] * 3), noise=NoiseModel(box_sigma=0.03), rng=0)
    result = _quiet_localize(session)
    for obj, oq in zip(result.objects, result.quality["objects"]):
        if obj.covariance is None:
            assert "do not determine the position" in oq["covariance_reason"]
        else:  # never a covariance that is not positive definite
            assert is_positive_definite(obj.covariance)
    assert any(o.covariance is None for o in result.objects)


def test_nees_of_clean_sessions_is_about_three() -> None:
    nees = []
    for seed in (0, 1, 2):
        for noise in (0.02, 0.10):
            case = make_case("paper", seed, noise)
            nees += _nees(_quiet_localize(case.session), case.centres)
    nees = np.array(nees)
    assert len(nees) >= 30
    assert 1.5 < nees.mean() < 5.0, nees.mean()  # 3 when calibrated; coarse bounds for 36 fruit
    assert np.mean(nees > NEES_95) < 0.2


def test_variance_factor_grows_with_box_noise() -> None:
    factors = [_quiet_localize(make_case("paper", 3, noise).session).quality["variance_factor"] for noise in (0.02, 0.10)]
    assert factors[1] > 3 * factors[0], factors  # 25 times the variance, less the sensor model's pixel floor


def test_positions_are_the_fits_only_the_covariance_changes() -> None:
    """The quality pass scales covariances: no position is moved (the pass before it gives them)."""
    from monovisual3d.methods.bayes import pipeline

    case = make_case("paper", 1, 0.05)
    problem, state = _state_before_quality(case)
    after = pipeline.PASSES[-1].run(problem, state)
    assert pipeline.PASSES[-1].name == "quality"
    assert len(after.objects) == len(state.objects)
    for a, b in zip(after.objects, state.objects):
        np.testing.assert_array_equal(a.position, b.position)
        assert a.associations == b.associations


def _state_before_quality(case: TrustCase) -> tuple[Problem, State]:
    """The problem and the state as the quality pass receives them (every pass before it run on ``case``'s views)."""
    from monovisual3d.methods.bayes import pipeline
    from monovisual3d.methods.bayes.problem import build_problem

    config = BayesConfig()
    loc = BayesLocalizer(case.session.camera, config)
    for v in case.session.views:
        loc.update(v)
    problem = build_problem(case.session.camera, config, loc.views, loc.grid)
    state = State()
    for p in pipeline.PASSES[:-1]:
        if p.runs(problem, state):
            state = p.run(problem, state)
    return problem, state


def test_a_leaf_cut_sphere_fitted_flat_is_covered_by_the_cut_spheres_spread() -> None:
    """A greenhouse fruit (a sphere, 37.5 mm) whose boxes leaves cut is fitted as a flattened spheroid 16 mm off; its
    covariance alone (NEES 180) does not cover that, the spread toward the cut sphere's reading of its boxes does."""
    case = make_case("greenhouse", 28, 0.02)
    problem, state = _state_before_quality(case)
    others = cut_spheres(problem, state.objects)
    assert [o.shape for o, c in zip(state.objects, others) if c is not None] == ["spheroid"]
    quality, objects = assess(problem, state.objects)
    (i,) = [i for i, c in enumerate(others) if c is not None]
    other, obj = others[i], objects[i]
    ei, ti = match(np.array([o.position for o in objects]), case.centres)
    err = obj.position - case.centres[dict(zip(ei, ti))[i]]
    assert 0.01 < np.linalg.norm(err) < 0.03  # the flat fit is off; the sphere the leaves cut is the truth
    assert np.linalg.norm(obj.position + other.offset - case.centres[dict(zip(ei, ti))[i]]) < 0.003
    assert other.weight > 0.5  # the leaves' cuts of one side counted once: the sphere is the likelier reading
    C = np.asarray(obj.covariance)
    assert is_positive_definite(C)
    assert float(err @ np.linalg.solve(C - other.spread, err)) > NEES_95  # the fitted model's covariance alone
    assert float(err @ np.linalg.solve(C, err)) < NEES_95


def test_one_occluder_cutting_a_side_in_every_view_costs_once() -> None:
    """A greenhouse fruit (a sphere, 29.9 mm) whose boxes a leaf cuts at the bottom in all five views is fitted
    as an oblate spheroid 9 mm off. Scored per view, the sphere the leaf cuts paid one ``inward_floor`` per view and
    its reading weighed 0.01: the covariance said 1-5 mm (NEES 88). Counted as one occluder it is the likelier
    reading, and the spread toward it covers the error."""
    from monovisual3d.methods.bayes.fits import as_answer, evidence_margin, sphere_answer

    case = make_case("greenhouse", 19, 0.02)
    problem, state = _state_before_quality(case)
    others = cut_spheres(problem, state.objects)
    _, objects = assess(problem, state.objects)
    ei, ti = match(np.array([o.position for o in objects]), case.centres)
    truth = dict(zip(ei, ti))
    (i,) = [i for i, c in enumerate(others) if c is not None and 0.005 < np.linalg.norm(c.offset) < 0.01]
    obj, other = state.objects[i], others[i]
    assert obj.shape == "spheroid"
    sphere = Found(obj.position + other.offset, obj.score, other.radius, associations=obj.associations)
    model_answer, sphere_reading = as_answer(problem, obj), sphere_answer(sphere)
    repeated = shared_cut_nats(problem, obj, sphere_reading)
    assert repeated >= 2 * problem.model.inward_floor  # three or more views cut on one side
    assert shared_cut_nats(problem, obj, model_answer) == 0.0  # the flattened model needs no cut
    per_view = evidence_margin(problem, obj, model_answer, sphere_reading, 4 * len(obj.associations))
    assert per_view > 0 > per_view - repeated  # per view the spheroid won; one occluder, the sphere
    assert other.weight > 0.5
    err = objects[i].position - case.centres[truth[i]]
    assert np.linalg.norm(err) > 0.005
    assert np.linalg.norm(sphere.position - case.centres[truth[i]]) < np.linalg.norm(err)  # the sphere is nearer
    C = np.asarray(objects[i].covariance)
    assert float(err @ np.linalg.solve(C - other.spread, err)) > NEES_95
    assert float(err @ np.linalg.solve(C, err)) < NEES_95


def _yaw(deg: float) -> np.ndarray:
    """A camera rotation turned by ``deg`` about the base frame's z axis (optical to base)."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _pitch(deg: float) -> np.ndarray:
    """A camera rotation turned by ``deg`` about its own x axis (optical to base)."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _cuts(*sides_per_view: tuple[int, ...]) -> np.ndarray:
    """A (K, 4) cut mask: the given ``bbox_xyxy`` sides of each view cut (0 left, 1 top, 2 right, 3 bottom)."""
    cut = np.zeros((len(sides_per_view), 4), dtype=bool)
    for v, sides in enumerate(sides_per_view):
        cut[v, list(sides)] = True
    return cut


@pytest.mark.parametrize(
    ("cut", "rotations", "expected"),
    [
        (_cuts((3,), (3,), (3,)), [_yaw(0), _yaw(20), _yaw(40)], 2),  # a bottom cut in three views of an arc: one occluder
        (_cuts((0,), (0,)), [_yaw(0), _yaw(20)], 1),  # a left side 20 degrees apart
        (_cuts((0,), (0,)), [_yaw(0), _yaw(90)], 0),  # a left side 90 degrees apart faces elsewhere: two occluders
        (_cuts((0,), (2,)), [_yaw(0), _yaw(180)], 0),  # facing the same way, but other image sides: not one
        (_cuts((3,), (3,)), [_pitch(0), _pitch(40)], 0),  # the bottom seen from level and from 40 degrees above
        (_cuts((1, 3), (1, 3), (1,)), [_yaw(0), _yaw(10), _yaw(20)], 2),  # two occluders: the larger group counts
        (_cuts((3,)), [_yaw(0)], 0),
        (_cuts(), [], 0),
    ],
)
def test_repeated_cuts_counts_one_occluders_cuts_seen_again(cut: np.ndarray, rotations: list, expected: int) -> None:
    R = np.array(rotations) if rotations else np.zeros((0, 3, 3))
    assert repeated_cuts(cut, R) == expected


def test_repeated_cuts_does_not_depend_on_the_views_order() -> None:
    """Left sides at 0, 20 and 40 degrees: 0 and 40 are too far apart for each other's cone, 20 is near both, and
    from 20 all three are one occluder's, whichever view comes first (a greedy grouping from the first view found
    two groups where 0 came first)."""
    left = np.zeros((3, 4), dtype=bool)
    left[:, 0] = True
    for order in ([0, 20, 40], [20, 0, 40], [40, 0, 20]):
        assert repeated_cuts(left, np.array([_yaw(d) for d in order])) == 2


def test_a_sphere_gets_no_cut_sphere_and_the_margin_decides_as_beats() -> None:
    from monovisual3d.methods.bayes.fits import as_answer, beats, evidence_margin, sphere_answer

    case = make_case("paper", 0, 0.02)
    problem, state = _state_before_quality(case)
    assert all(c is None for c in cut_spheres(problem, state.objects))  # every object a sphere
    o = state.objects[0]
    bigger = Found(o.position, o.score, 1.2 * float(o.radius), associations=o.associations)
    a, b = as_answer(problem, o), sphere_answer(bigger)
    n = 4 * len(o.associations)
    margin = evidence_margin(problem, o, a, b, n)
    assert margin == pytest.approx(-evidence_margin(problem, o, b, a, n))  # same parameter count: antisymmetric
    assert margin > 0 and beats(problem, o, a, b, n) and not beats(problem, o, b, a, n)


def test_object_factor_shrinks_toward_the_session() -> None:
    assert object_factor(8.0, 8) == pytest.approx(1.0)
    assert 1.0 < object_factor(40.0, 8) < 5.0  # its own chi-square says 5, the prior of 10 dof says 1
    assert object_factor(400.0, 200) == pytest.approx(410 / 210)


def test_scatter_fires_only_on_evidence() -> None:
    assert [c.cause for c in causes_of(Quality(variance_factor=40.0, dof=60))] == ["scatter"]
    assert causes_of(Quality(variance_factor=40.0, dof=4)) == ()  # too few degrees of freedom
    assert causes_of(Quality(variance_factor=5.0, dof=600)) == ()  # 10 % box noise is no alarm
    unexplained = causes_of(Quality(unexplained_boxes=tuple((v, 0) for v in range(8)), n_boxes=20))
    assert [c.cause for c in unexplained] == ["unexplained_boxes"] and "8 of 20" in unexplained[0].message


def _scattered_session(tmp_path: Path) -> Path:
    """The paper scene from five views with 40 % box noise: the boxes sit far beyond the sensor model's noise."""
    scene = paper_scene()
    session, _ = simulate(scene, default_camera(), paper_poses(scene_target(scene)), noise=NoiseModel(box_sigma=0.4), rng=5)
    path = tmp_path / "scattered.json"
    path.write_text(json.dumps(session.to_dict()))
    return path


def test_the_live_localizer_says_what_localize_says(tmp_path: Path) -> None:
    from monovisual3d import load_session

    session = load_session(_scattered_session(tmp_path))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = localize(session)
    loc = BayesLocalizer(session.camera, BayesConfig())
    for view in session.views:
        loc.update(view)
    with pytest.warns(InputWarning) as live:
        loc.estimate()
    assert loc.last is not None
    assert loc.last.warnings == result.warnings and result.warnings
    assert loc.last.quality == result.quality
    assert [str(w.message) for w in live if w.category is InputWarning] == result.warnings
    assert set(result.warnings) <= {str(w.message) for w in caught}


def test_strict_exits_1_on_a_suspect_verdict_and_names_the_cause(tmp_path: Path) -> None:
    from monovisual3d.cli import app

    path, out = _scattered_session(tmp_path), tmp_path / "r.json"
    run = CliRunner().invoke(app, ["localize", str(path), "--strict", "-q", "-o", str(out)])
    quality = json.loads(out.read_text())["quality"]
    assert quality["verdict"] == "suspect" and "scatter" in [c["cause"] for c in quality["causes"]]
    assert run.exit_code == 1
    assert "warning: scatter:" in run.stderr


def test_batch_tables_carry_the_quality_and_the_shape() -> None:
    from monovisual3d.batch.tables import FRUIT_COLUMNS, SESSION_COLUMNS
    from monovisual3d.batch.work import fruit_rows, quality_columns

    result = _quiet_localize(make_case("paper", 0, 0.05).session)
    session = quality_columns(result)
    assert session["verdict"] == "ok" and session["causes"] == "" and session["variance_factor"] > 0
    assert np.isnan(session["edge_noise_alpha"])  # boxes as noisy as the model says: not raised
    rows = fruit_rows("s", result)
    for row, obj in zip(rows, result.objects):
        assert row["shape"] == obj.shape
        np.testing.assert_allclose(json.loads(row["semi_axes_m"]), obj.semi_axes)
        np.testing.assert_allclose(json.loads(row["quaternion_xyzw"]), obj.quaternion_xyzw)
        assert row["residual_chi2"] >= 0 and row["dof"] > 0
    assert set(rows[0]) <= set(FRUIT_COLUMNS) and set(session) <= set(SESSION_COLUMNS)


def test_a_free_box_at_an_objects_prediction_is_explained_a_stray_one_is_not() -> None:
    """A second box on a found fruit (a detector's duplicate) is explained by it; a box away from every fruit is not,
    and only that one is listed; alone in its view, it is a false positive, not a missed fruit: no warning."""
    from monovisual3d.completeness import incomplete_reasons
    from monovisual3d.session.load import load_session

    data = make_case("paper", 2, 0.02).session.to_dict()
    first = data["views"][0]["detections"]
    duplicate = {"bbox_xyxy": [c + 1.0 for c in first[0]["bbox_xyxy"]]}
    first += [duplicate, {"bbox_xyxy": [2.0, 2.0, 22.0, 22.0]}]
    session = load_session(data)
    result = _quiet_localize(session)
    n = len(first)
    assert result.quality["unexplained_boxes"] == [[0, n - 1]]
    assert incomplete_reasons(session, result) == []


def test_the_live_localizer_names_input_mistakes_as_localize_does() -> None:
    from monovisual3d.session import Session

    clean, _ = simulate(paper_scene(), default_camera(), paper_poses(), noise=NoiseModel(box_sigma=0.02), rng=3)
    twice = Session(clean.camera, clean.views + clean.views)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = localize(twice)
    loc = BayesLocalizer(twice.camera, BayesConfig())
    for view in twice.views:
        loc.update(view)
    with pytest.warns(InputWarning, match="duplicate"):
        loc.estimate()
    assert loc.last is not None
    assert loc.last.warnings == result.warnings
    assert [c["cause"] for c in loc.last.quality["causes"]] == [c["cause"] for c in result.quality["causes"]]
    assert "duplicate_views" in [c["cause"] for c in result.quality["causes"]]
    assert loc.last.quality["verdict"] == result.quality["verdict"] != "ok"
