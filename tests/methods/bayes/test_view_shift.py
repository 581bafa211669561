"""Views whose boxes all sit off the same way are reported: a pose that is off, not noise."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import monovisual3d as mv
from monovisual3d.errors import InputWarning
from monovisual3d.methods.bayes.view_shift import MIN_SHIFT_PX, shift_message
from monovisual3d.session import Session, View
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.simulate import simulate


def _session(seed: int, turn_deg: float = 0.0, view: int = 1, noise: NoiseModel | None = None) -> Session:
    """The paper scene's three views, view ``view``'s reported pose turned by ``turn_deg`` about its camera's y axis
    (its boxes move along u)."""
    session, _ = simulate(paper_scene(), noise=noise or NoiseModel(), rng=seed)
    views = list(session.views)
    T = views[view].T_base_optical.copy()
    T[:3, :3] = T[:3, :3] @ Rotation.from_rotvec([0.0, np.radians(turn_deg), 0.0]).as_matrix()
    views[view] = View(T, views[view].detections)
    return Session(session.camera, tuple(views), session.workspace)


def _localize(session: Session, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = mv.localize(session, **options)
    return result, [str(w.message) for w in caught if issubclass(w.category, InputWarning)]


def test_a_view_turned_by_two_degrees_is_reported_with_its_shift_along_u():
    result, said = _localize(_session(0, turn_deg=2.0))
    shifts = {s["view"]: s for s in result.diagnostics["view_shifts"]}
    assert 1 in shifts, result.diagnostics["view_shifts"]
    du, dv = shifts[1]["shift_px"]
    assert abs(du) > 3 * abs(dv) and abs(du) >= MIN_SHIFT_PX
    assert shifts[1]["n_objects"] >= 2 and shifts[1]["chi2"] > 25
    assert any(w.startswith("views[1]: the boxes of its") and "--pose-sigma-deg" in w for w in said)
    assert result.warnings == said


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_views_with_right_poses_are_not_reported_under_the_papers_box_noise(seed):
    result, said = _localize(_session(seed, noise=NoiseModel.paper()))
    assert result.diagnostics["view_shifts"] == []
    assert not any("sit " in w for w in said)


def test_nothing_is_reported_where_the_pose_error_is_stated_and_corrected():
    result, said = _localize(_session(0, turn_deg=2.0), pose_sigma_mm=2.0, pose_sigma_deg=1.0)
    assert result.diagnostics["view_shifts"] == []
    assert not any("sit " in w for w in said)


def test_the_message_names_the_view_and_the_rotation_the_shift_amounts_to():
    text = shift_message({"view": 4, "shift_px": [10.0, -0.4], "n_objects": 3, "chi2": 40.0}, 500.0)
    assert text.startswith("views[4]: the boxes of its 3 objects seen in 3 or more views sit +10, -0 px (u, v)")
    assert "about 1.1 degrees" in text and "\n" not in text
