"""``bench trust``: the scoring of one session on hand-made cases, a small run, the tables and the CLI."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from monovisual3d.bench.trust import check_targets, format_markdown, measure_case, mistake_rng, run_trust, save, summarise
from monovisual3d.bench.trust_cases import FAMILIES, distortion_folds, make_case
from monovisual3d.bench.trust_runs import (
    NEES_95,
    Outcome,
    clean_record,
    cpu_time_limit,
    fruit_nees,
    is_positive_definite,
    names_cause,
    run_session,
    same_answer,
    score_session,
)
from monovisual3d.budget import TimeLimitExceeded
from monovisual3d.camera import Camera
from monovisual3d.cli import app
from monovisual3d.errors import InputError
from monovisual3d.sim.mistakes import xywh_boxes

CENTRES = np.array([[0.6, 0.0, 0.45], [0.6, 0.1, 0.45]])
RADII = np.array([0.03, 0.03])
MM2 = 1e-6  # 1 mm^2 in m^2


def answered(positions, sigma_mm=1.0, messages=(), exit_code=0):
    P = np.asarray(positions, dtype=float)
    return Outcome(exit_code, messages=list(messages), positions=P, covariances=[np.eye(3) * (sigma_mm**2 * MM2)] * len(P))


def test_nees_of_a_hand_made_answer():
    """2 mm off along x with a 1 mm sigma: NEES 4; an object far from any fruit is not scored."""
    out = answered([CENTRES[0] + [0.002, 0, 0], CENTRES[1] + [0, 0.2, 0]])
    assert_allclose(fruit_nees(out, CENTRES, RADII), [4.0])
    out.covariances[0] = None
    assert fruit_nees(out, CENTRES, RADII) == [None]
    assert not is_positive_definite(np.diag([1.0, 1.0, -3e10])) and not is_positive_definite(
        np.array([[1, 2, 0], [0, 1, 0], [0, 0, 1.0]])
    )
    assert is_positive_definite(np.eye(3) * 1e-8)


def test_a_refused_session_is_caught_whatever_its_words():
    clean = answered(CENTRES)
    refused = Outcome(2, "views[0].detections[0].bbox_xyxy: has x2 <= x1")
    record = score_session(refused, clean, CENTRES, RADII, ("x,y,w,h",))
    assert record["caught"] and record["refused"] and not record["named"] and record["error_mm"] is None
    named = score_session(Outcome(2, "boxes look like X,Y,W,H"), clean, CENTRES, RADII, ("x,y,w,h",))
    assert named["named"]  # case-insensitive


def test_flagged_needs_the_strict_exit_and_a_message():
    clean = answered(CENTRES)
    wrong = [CENTRES[0] + [0.05, 0, 0], CENTRES[1]]
    silent = score_session(answered(wrong), clean, CENTRES, RADII, ("hand-eye",))
    assert not silent["caught"] and not silent["harmless"]
    assert_allclose(silent["error_mm"], 25.0)
    warned_only = score_session(
        answered(wrong, messages=["check the hand-eye calibration"]), clean, CENTRES, RADII, ("hand-eye",)
    )
    assert not warned_only["caught"] and warned_only["named"]  # a warning without the strict exit 1 is not a flag
    flagged = score_session(
        answered(wrong, messages=["check the hand-eye calibration"], exit_code=1), clean, CENTRES, RADII, ("hand-eye",)
    )
    assert flagged["caught"] and flagged["flagged"] and flagged["named"]
    assert not score_session(answered(wrong, exit_code=1), clean, CENTRES, RADII, ("x",))["flagged"]  # no message


def test_harmless_means_the_clean_answer_with_covariances_that_cover_the_error():
    clean = answered(CENTRES + [0.001, 0, 0])
    same = answered(CENTRES + [0.002, 0, 0], sigma_mm=2.0)  # 1 mm from the clean answer, NEES 1
    assert score_session(same, clean, CENTRES, RADII, ("x",))["caught"]
    too_sure = answered(CENTRES + [0.002, 0, 0], sigma_mm=0.5)  # NEES 16: the covariance does not cover the error
    assert not score_session(too_sure, clean, CENTRES, RADII, ("x",))["caught"]
    moved = answered(CENTRES + [0.0045, 0, 0], sigma_mm=10.0)  # 3.5 mm from the clean answer
    assert not same_answer(moved, clean) and not score_session(moved, clean, CENTRES, RADII, ("x",))["caught"]
    lost = answered(CENTRES[:1], sigma_mm=10.0)
    assert not same_answer(lost, clean)
    assert NEES_95 == pytest.approx(7.815, abs=1e-3)


def test_stopped_and_crashed_runs_are_neither_caught_nor_named():
    clean = answered(CENTRES)
    for out in (Outcome(1, "stopped after 10 CPU seconds", timed_out=True), Outcome(1, "ValueError: hand-eye", crashed=True)):
        record = score_session(out, clean, CENTRES, RADII, ("hand-eye", "stopped"))
        assert not record["caught"] and not record["named"] and not record["refused"]
    assert names_cause(Outcome(0, messages=["Views[2] disagrees"]), ("views[2]",))


def test_run_session_like_the_cli():
    case = make_case("paper", 0, 0.02)
    clean = run_session(case.session)
    assert clean.exit_code == 0 and len(clean.positions) == 6 and clean.runtime_s > 0
    record = clean_record(clean, case.centres, case.radii)
    assert record["error_mm"] < 5 and len(record["nees"]) == 6 and record["not_pd"] == 0
    refused = run_session(xywh_boxes(case.session.to_dict()))
    assert refused.refused and "x2 <= x1" in refused.error


def test_cpu_time_limit_stops_a_busy_loop():
    with pytest.raises(TimeLimitExceeded):
        with cpu_time_limit(0.2):
            end = time.perf_counter() + 60.0
            while time.perf_counter() < end:
                pass
    with cpu_time_limit(5.0):
        pass  # a block that ends in time leaves nothing behind


def test_cases_are_seeded_and_their_lenses_never_fold():
    a, b = make_case("arc", 3, 0.05), make_case("arc", 3, 0.05)
    assert a.session.to_dict() == b.session.to_dict() and a.frames is not None
    assert a.session.camera.distortion_model == "plumb_bob" and not distortion_folds(a.session.camera)
    assert make_case("row", 3, 0.05).views.startswith("row:")
    folding = Camera(960, 540, 625.5, 625.5, 480, 270, "plumb_bob", (-0.18, 0.064, 0, 0, -0.075))
    assert distortion_folds(folding)  # its image corners lie beyond the model's largest radius
    with pytest.raises(ValueError, match="family"):
        make_case("orchard", 0, 0.05)


@pytest.fixture(scope="module")
def small():
    return run_trust(seeds=(0,), families=("paper",), noises=(0.05,), mistakes=("boxes-xywh", "views-twice", "one-pose"))


def test_a_small_run_gives_every_table(small, tmp_path):
    assert set(small["mistakes"]) == {"boxes-xywh", "views-twice", "one-pose"}
    xywh = small["mistakes"]["boxes-xywh"]
    assert xywh["sessions"] == 1 and xywh["caught"] == 1.0 and xywh["refused"] == 1.0  # the loader refuses w < x
    assert small["overall"]["sessions"] == 3
    assert small["clean"]["sessions"] == 1 and set(small["nees"]) == {"0.05"}
    assert small["nees"]["0.05"]["fruit"] == 6
    md = format_markdown(small)
    for header in ("| mistake | cause | sessions | caught |", "| clean sessions |", "| box noise | fruit | mean NEES |"):
        assert header in md
    assert "| boxes-xywh | box_coordinates | 1 | 100 % | 100 % |" in md
    rows = {what: (value, met) for what, value, _, met in check_targets(small)}
    assert rows["mistaken sessions caught"][0] == pytest.approx(small["overall"]["caught"])
    save(small, str(tmp_path / "trust.json"))
    assert json.loads((tmp_path / "trust.json").read_text())["cases"][0]["case"]["family"] == "paper"


def test_the_summary_pools_hand_made_records():
    def rec(family, sigma, alarm, nees, mistakes):
        clean = {
            "alarm": alarm,
            "timed_out": False,
            "nees": nees,
            "not_pd": 0,
            "error_mm": 3.0,
            "runtime_s": 1.0,
            "cpu_s": 1.0,
            "messages": ["w"] if alarm else [],
        }
        case = {"family": family, "box_sigma": sigma, "n_views": 5, "n_fruit": 6}
        return {"case": case, "clean": clean, "mistakes": mistakes}

    m = {
        "caught": True,
        "refused": True,
        "flagged": False,
        "harmless": False,
        "named": False,
        "cause_named_by_id": False,
        "crashed": False,
        "timed_out": False,
        "not_pd": 0,
        "error_mm": None,
        "clean_error_mm": 3.0,
        "self_calibrated": None,
        "runtime_s": 0.1,
        "cpu_s": 0.1,
    }
    records = [
        rec("paper", 0.02, False, [1.0, 9.0], {"boxes-xywh": m}),
        rec("arc", 0.02, True, [2.0, None], {"boxes-xywh": {**m, "caught": False, "refused": False}}),
    ]
    s = summarise(records)
    assert s["clean"]["false_alarm"] == 0.5 and s["clean"]["by_family"]["arc"]["false_alarm"] == 1.0
    assert s["mistakes"]["boxes-xywh"]["caught"] == 0.5 and s["overall"]["caught"] == 0.5
    n = s["nees"]["0.02"]
    assert (
        n["fruit"] == 4
        and n["without_covariance"] == 1
        and n["mean"] == pytest.approx(4.0)
        and n["beyond_95"] == pytest.approx(1 / 3)
    )


def test_measure_case_skips_mistakes_a_case_cannot_have():
    out = measure_case("paper", 0, 0.05, ("poses-frame-late", "distortion-signs"))
    assert out["mistakes"] == {}  # the paper family has no path and no lens distortion


def test_a_mistakes_draws_do_not_depend_on_the_others_run():
    a = mistake_rng("arc", 3, "hand-eye-2deg").normal(size=3)
    assert_allclose(a, mistake_rng("arc", 3, "hand-eye-2deg").normal(size=3))
    assert not np.allclose(a, mistake_rng("arc", 3, "hand-eye-1cm").normal(size=3))
    assert not np.allclose(a, mistake_rng("row", 3, "hand-eye-2deg").normal(size=3))


def test_bad_choices_are_refused_by_name():
    with pytest.raises(InputError, match="--families"):
        run_trust(families=("orchard",))
    with pytest.raises(InputError, match="--mistakes .*'nope'"):
        run_trust(mistakes=("nope",))
    with pytest.raises(InputError, match="--seeds"):
        run_trust(seeds=(-1,))
    assert set(FAMILIES) == {"paper", "greenhouse", "arc", "row"}


def test_cli_bench_trust(tmp_path):
    out = tmp_path / "t.json"
    res = CliRunner().invoke(
        app, ["bench", "trust", "--seeds", "1", "--families", "paper", "--mistakes", "boxes-xywh", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "| boxes-xywh |" in res.stdout and out.exists()
    assert json.loads(out.read_text())["noises"] == [0.02, 0.05, 0.1]
    bad = CliRunner().invoke(app, ["bench", "trust", "--families", "orchard"])
    assert bad.exit_code == 2 and "--families" in bad.stderr
