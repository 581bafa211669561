"""The small Levenberg-Marquardt solver against its reference, scipy's least_squares."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares

from monovisual3d.camera import Camera
from monovisual3d.frames import invert_transform, look_at
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.methods.bayes.levenberg import forward_jacobian, levenberg_marquardt
from monovisual3d.methods.bayes.likelihood import SensorModel
from monovisual3d.methods.bayes.refine import SPHERE_X_SCALE, Observation, _SphereResiduals, robust_loss

CAM = Camera.from_hfov(640, 480, 69.0)
TARGET = np.array([0.7, 0.0, 0.5])
#: three views 0.5 m from the target, 0.15 m apart, as in the paper's layout
POSES = [look_at(TARGET + off, TARGET) for off in ([-0.5, 0, 0], [-0.45, 0.15, -0.15], [-0.45, -0.15, 0.15])]


def _exponentials(X: np.ndarray, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residuals of y = a exp(-b t) + c for parameter rows (a, b, c)."""
    return X[:, :1] * np.exp(-X[:, 1:2] * t) + X[:, 2:3] - y


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("robust", [False, True])
def test_minimum_cost_and_jacobian_match_scipy(seed: int, robust: bool) -> None:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 4.0, 30)
    truth = np.array([2.0, 1.3, 0.5]) + rng.normal(0, 0.2, 3)
    y = _exponentials(truth[None], t, 0.0)[0] + rng.normal(0, 0.02, t.size)
    y[rng.choice(t.size, 3, replace=False)] += 1.0  # outliers the robust loss stops following
    x0, scale = np.array([1.0, 1.0, 0.0]), np.ones(3)
    loss = robust_loss(3.0) if robust else None
    sol = levenberg_marquardt(lambda X: _exponentials(X, t, y), x0, scale, loss=loss, max_nfev=200)
    ref = least_squares(lambda x: _exponentials(x[None], t, y)[0], x0, loss=loss or "linear", x_scale=scale, method="trf")
    assert sol.success and ref.success
    # both stop on the cost's relative change (1e-8): the same minimum, x to where the cost is that flat
    assert_allclose(sol.x, ref.x, atol=1e-4)
    assert sol.cost <= ref.cost * (1 + 1e-7)
    assert_allclose(sol.jac, ref.jac, rtol=1e-3, atol=1e-5)  # both scaled by the loss, at x equal to 1e-4


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


def test_forward_jacobian_is_exact_on_a_linear_map() -> None:
    A = np.random.default_rng(1).normal(size=(6, 3))
    x = np.array([0.3, -2.0, 5.0])
    assert_allclose(forward_jacobian(lambda X: X @ A.T, x, A @ x), A, atol=1e-6)


def test_non_finite_residuals_end_within_the_budget() -> None:
    sol = levenberg_marquardt(lambda X: np.full((len(X), 3), np.nan), np.zeros(2), np.ones(2), max_nfev=10)
    assert not sol.success and sol.nfev <= 10
