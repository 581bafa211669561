"""The sphere refinement's solver against scipy's least_squares on the same residuals."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares

from monovisual3d.camera import Camera
from monovisual3d.frames import invert_transform, look_at
from monovisual3d.geometry.levenberg import levenberg_marquardt
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.methods.bayes.refine import (
    MAX_NFEV,
    SPHERE_X_SCALE,
    SPHEROID_X_SCALE,
    Observation,
    _OneSidedResiduals,
    _SphereResiduals,
    _SpheroidResiduals,
    refine_sphere,
    refine_spheroid,
    robust_loss,
)
from monovisual3d.methods.bayes.sensor import SensorModel

CAM = Camera.from_hfov(640, 480, 69.0)
TARGET = np.array([0.7, 0.0, 0.5])
#: three views 0.5 m from the target, 0.15 m apart, as in the paper's layout
POSES = [look_at(TARGET + off, TARGET) for off in ([-0.5, 0, 0], [-0.45, 0.15, -0.15], [-0.45, -0.15, 0.15])]


@pytest.mark.parametrize("seed", range(4))
def test_sphere_refinement_matches_scipy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    centre, radius = TARGET + rng.normal(0, 0.02, 3), 0.03
    obs = [Observation(invert_transform(T), sphere_bbox(CAM, T, centre[None], radius)[0] + rng.normal(0, 1.0, 4)) for T in POSES]
    f = _SphereResiduals(CAM, obs, SensorModel())
    x0 = np.concatenate([centre + rng.normal(0, 0.01, 3), [np.log(0.025)]])
    loss = robust_loss(SensorModel().inward_floor)
    sol = levenberg_marquardt(f.params_batch, x0, SPHERE_X_SCALE, loss=loss, max_nfev=60)
    ref = least_squares(f, x0, loss=loss, x_scale=SPHERE_X_SCALE, method="trf", max_nfev=60)
    assert_allclose(sol.x[:3], ref.x[:3], atol=1e-9)  # metres: the same steps, to rounding
    assert_allclose(sol.cost, ref.cost, rtol=1e-9)
    assert sol.nfev == ref.nfev <= 20


def _noisy_boxes(seed: int) -> tuple[np.random.Generator, np.ndarray, list[Observation]]:
    rng = np.random.default_rng(seed)
    centre = TARGET + rng.normal(0, 0.02, 3)
    obs = [Observation(invert_transform(T), sphere_bbox(CAM, T, centre[None], 0.03)[0] + rng.normal(0, 1.0, 4)) for T in POSES]
    return rng, centre, obs


@pytest.mark.parametrize("seed", range(3))
def test_one_sided_refit_matches_scipy(seed: int) -> None:
    """The shape stage's final refit (``floors``: a plain squared loss on mapped residuals)."""
    rng, centre, obs = _noisy_boxes(seed)
    obs[0].bbox_xyxy[2] -= 6.0  # one edge cut inward
    model, floors = SensorModel(), (1.5, 6.0)
    x0 = np.concatenate([centre + rng.normal(0, 0.01, 3), [np.log(0.025)]])
    got = refine_sphere(CAM, obs, x0[:3], 0.025, model, use_masks=False, floors=floors)
    f = _OneSidedResiduals(CAM, obs, model, floors, use_masks=False)
    ref = least_squares(f, x0, x_scale=SPHERE_X_SCALE, method="trf", max_nfev=MAX_NFEV)
    assert got.success and ref.success
    assert_allclose(got.centre, ref.x[:3], atol=1e-9)
    assert_allclose(got.radius, np.exp(ref.x[3]), rtol=1e-7)
    assert_allclose(got.cost, ref.cost, rtol=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_spheroid_refinement_matches_scipy(seed: int) -> None:
    rng, centre, obs = _noisy_boxes(seed)
    model, up = SensorModel(), np.array([0.0, 0.0, 1.0])
    x0 = np.concatenate([centre + rng.normal(0, 0.01, 3), np.log([0.025, 0.04])])
    got = refine_spheroid(CAM, obs, x0[:3], 0.025, 0.04, model, up)
    f = _SpheroidResiduals(CAM, obs, model, up)
    ref = least_squares(f, x0, loss=robust_loss(model.inward_floor), x_scale=SPHEROID_X_SCALE, method="trf", max_nfev=MAX_NFEV)
    assert_allclose(got.centre, ref.x[:3], atol=1e-9)
    assert_allclose([got.radius, got.semi_up], np.exp(ref.x[3:]), rtol=1e-7)
    assert_allclose(got.cost, ref.cost, rtol=1e-9)
