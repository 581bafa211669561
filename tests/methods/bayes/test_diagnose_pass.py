"""The ``diagnose`` pass names a mistake every view shares, stays silent on clean sessions and changes no estimate;
``calibrate="hand-eye"`` estimates, applies and reports the correction."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

import monovisual3d as mv
from monovisual3d.errors import InputWarning
from monovisual3d.methods.bayes import pipeline
from monovisual3d.methods.bayes.config import BayesConfig
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.metrics import match
from monovisual3d.session.load import load_session
from monovisual3d.sim.mistakes import hand_eye_error, hand_eye_offset
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import default_camera, random_scene, scene_target
from monovisual3d.sim.simulate import simulate
from monovisual3d.sim.viewpoints import hemisphere_poses


def _sessions(seed: int, n_views: int = 8, rotation_deg: float = 2.0, translation_mm: float = 10.0):
    """A clean session of 7 fruit seen from views of diverse rotation, the same with a hand-eye error, the fruit and
    the error ``E`` (reported poses ``T @ E``)."""
    rng = np.random.default_rng(seed)
    scene = random_scene(7, rng)
    poses = hemisphere_poses(scene_target(scene), n_views)
    session, _ = simulate(scene, default_camera(), poses, noise=NoiseModel(box_sigma=0.05), rng=rng)
    E = hand_eye_offset(rotation_deg, translation_mm, rng)
    return session, load_session(hand_eye_error(session.to_dict(), E)), scene, E


def _localize(session, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = mv.localize(session, **options)
    return result, [str(w.message) for w in caught if issubclass(w.category, InputWarning)]


def _error_mm(result, centres) -> float:
    ei, ti = match(result.positions, centres)
    return float(np.mean(np.linalg.norm(result.positions[ei] - centres[ti], axis=1)) * 1e3)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_hand_eye_error_is_named_on_views_of_diverse_rotation(seed):
    _, bad, _, _ = _sessions(seed)
    result, said = _localize(bad)
    causes = [c["cause"] for c in result.quality["causes"]]
    assert "hand_eye" in causes or "image_size" in causes, result.quality
    named = [w for w in said if "hand-eye" in w]
    assert named and "--calibrate hand-eye" in named[0]
    assert result.quality["verdict"] == "suspect"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_clean_session_gets_no_cause(seed):
    clean, _, _, _ = _sessions(seed)
    result, said = _localize(clean)
    assert result.quality["causes"] == [] and result.quality["verdict"] == "ok"
    assert not any("one pattern" in w for w in said)


def test_the_pass_changes_no_estimate(monkeypatch):
    _, bad, _, _ = _sessions(0)
    config = BayesConfig()
    problem = build_problem(bad.camera, config, bad.views)
    from monovisual3d.methods.bayes.localizer import region_grid

    problem = replace(problem, region=region_grid(config, None, bad.views[0]))
    with_pass = pipeline.estimate(problem)
    monkeypatch.setattr(pipeline, "PASSES", tuple(p for p in pipeline.PASSES if p.name != "diagnose"))
    without = pipeline.estimate(problem)
    assert with_pass.causes and not any(c.cause == "hand_eye" for c in without.causes)
    np.testing.assert_array_equal(
        np.stack([o.position for o in with_pass.objects]), np.stack([o.position for o in without.objects])
    )


def test_calibrate_hand_eye_reports_and_applies_its_correction():
    clean, bad, scene, E = _sessions(1)
    plain, _ = _localize(bad)
    result, said = _localize(bad, calibrate="hand-eye")
    cal = result.quality["calibration"]
    assert cal["applied"] and not any("calibrate='hand-eye'" in w for w in said)
    assert cal["rotation_deg"] == pytest.approx(2.0, abs=0.7)
    assert cal["rotation_std_deg"] > 0 and len(cal["axis_optical"]) == 3 and "translation_mm" in cal
    assert _error_mm(result, scene.centres) < _error_mm(plain, scene.centres) - 3.0
    assert not any(c["cause"] == "hand_eye" for c in result.quality["causes"])


def test_calibrate_hand_eye_with_too_few_views_says_why_and_runs_as_usual():
    clean, bad, _, _ = _sessions(0, n_views=3)
    result, said = _localize(bad, calibrate="hand-eye")
    assert not result.quality["calibration"]["applied"]
    assert any(w.startswith("calibrate='hand-eye': 3 views") for w in said)
    np.testing.assert_allclose(result.positions, _localize(bad)[0].positions)


@pytest.mark.parametrize("seed", [0, 1])
def test_calibrate_hand_eye_applies_nothing_to_correct_poses(seed):
    """On correct poses the joint fit still finds a small correction from the noise; applied, it would move the fruit
    off: it is reported and not applied, and the fruit are those of a run without calibration."""
    clean, _, _, _ = _sessions(seed)
    result, said = _localize(clean, calibrate="hand-eye")
    cal = result.quality["calibration"]
    assert not cal["applied"] and "rotation_deg" in cal and cal["note"].startswith("hand-eye correction not applied")
    assert any("no hand-eye error beyond the noise" in w for w in said)
    np.testing.assert_allclose(result.positions, _localize(clean)[0].positions)


def test_calibrate_is_checked_by_name():
    with pytest.raises(mv.InputError, match="calibrate: got 'eye'"):
        BayesConfig(calibrate="eye")


def test_a_view_whose_boxes_fit_no_object_is_named_alone():
    from monovisual3d.methods.bayes.diagnose import disagreeing_views

    counts = {0: (0, 6), 1: (1, 6), 2: (5, 6), 3: (0, 6), 4: (1, 6)}
    (cause,) = disagreeing_views(counts)
    assert cause.cause == "view_disagrees" and cause.views == (2,) and cause.message.startswith("views[2]: 5 of its 6")
    # two views standing out together (a swap) are both named; a spread of a few free boxes names none
    assert [c.views for c in disagreeing_views({**counts, 0: (4, 6)})] == [(2,), (0,)]
    assert disagreeing_views({0: (2, 6), 1: (2, 6), 2: (3, 6), 3: (1, 6)}) == []


def test_a_view_holding_another_views_boxes_is_named_by_the_pipeline():
    from monovisual3d.bench.trust_cases import make_case
    from monovisual3d.sim.mistakes import boxes_from_other_view

    case = make_case("paper", 0, 0.02)
    bad = load_session(boxes_from_other_view(case.session.to_dict(), 2, 4))
    result, said = _localize(bad)
    assert any(c["cause"] == "view_disagrees" and c["views"] == [2] for c in result.quality["causes"])
    assert any(w.startswith("views[2]: ") for w in said)
