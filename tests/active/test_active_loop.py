"""The simulated loop's baselines: the fixed sequence and the view-sphere heuristic."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.active.loop import fixed_sequence, run_loop, sphere_pick
from monovisual3d.errors import InputError
from monovisual3d.frames import look_at
from monovisual3d.sim import default_camera, paper_poses, paper_scene

TARGET = np.array([0.6, 0.0, 0.45])


def test_fixed_sequence_starts_with_the_paper_poses_and_stays_on_their_ring() -> None:
    P = fixed_sequence(TARGET, 8)
    assert_allclose(P[:3], paper_poses(TARGET))
    d = np.linalg.norm(P[:, :3, 3] - TARGET, axis=1)
    assert_allclose(d[1:], d[1], rtol=1e-9)  # every pose after the first at the paper's 0.57 m
    ang = np.degrees(np.arccos((P[1:, :3, 3] - TARGET) @ (P[0, :3, 3] - TARGET) / d[1:] / d[0]))
    assert_allclose(ang, ang[0], atol=1e-9)
    assert len({tuple(np.round(p[:3, 3], 6)) for p in P}) == 8
    with pytest.raises(InputError, match="at most 9"):
        fixed_sequence(TARGET, 10)


def test_sphere_heuristic_maximises_the_smallest_angle() -> None:
    views = [look_at([0.1, 0.0, 0.45], TARGET)]
    cands = np.stack(
        [look_at(TARGET + 0.5 * np.array([-math.cos(a), math.sin(a), 0.0]), TARGET) for a in np.radians([5, 30, 60])]
    )
    assert sphere_pick(views, cands, TARGET, set()) == 2
    assert sphere_pick(views, cands, TARGET, {2}) == 1


def test_run_loop_rejects_unknown_strategy() -> None:
    with pytest.raises(InputError, match="strategy: got 'best'"):
        run_loop(paper_scene(), default_camera(), paper_poses(TARGET), 2, strategy="best", target=TARGET)


def test_the_loop_keeps_one_hand_eye_error_for_the_whole_session() -> None:
    """Views taken one at a time share the session's hand-eye error, as a real arm's calibration does."""
    from monovisual3d.sim.noise import NoiseModel

    noise = NoiseModel.from_mm_deg(hand_eye_error_mm=2.0, hand_eye_error_deg=0.5)
    run = run_loop(paper_scene(), default_camera(), paper_poses(TARGET), 3, strategy="fixed", target=TARGET, noise=noise, rng=1)
    E = [np.linalg.inv(step.T_base_optical) @ view.T_base_optical for step, view in zip(run.steps, run.session.views)]
    assert len(E) == 3
    assert_allclose(E[1], E[0], atol=1e-12)
    assert_allclose(E[2], E[0], atol=1e-12)
    assert np.linalg.norm(E[0][:3, 3]) > 1e-4
