"""The sphere refinement's solver against scipy's least_squares on the same residuals."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares

from monovisual3d.camera import Camera
from monovisual3d.frames import invert_transform, look_at
from monovisual3d.geometry.levenberg import levenberg_marquardt
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.methods.bayes.likelihood import SensorModel
from monovisual3d.methods.bayes.refine import SPHERE_X_SCALE, Observation, _SphereResiduals, robust_loss

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
    assert_allclose(sol.x[:3], ref.x[:3], atol=1e-6)  # metres: a micrometre
    assert_allclose(sol.cost, ref.cost, rtol=1e-6)
    assert sol.nfev <= 20
