"""The small Levenberg-Marquardt solver against its reference, scipy's least_squares."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import least_squares

from monovisual3d.geometry.levenberg import forward_jacobian, levenberg_marquardt, named_loss, trust_region_step


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
    loss = named_loss("cauchy", 0.1) if robust else None
    sol = levenberg_marquardt(lambda X: _exponentials(X, t, y), x0, scale, loss=loss, max_nfev=200)
    ref = least_squares(lambda x: _exponentials(x[None], t, y)[0], x0, loss=loss or "linear", x_scale=scale, method="trf")
    assert sol.success and ref.success
    # both stop on the cost's relative change (1e-8): the same minimum, x to where the cost is that flat
    assert_allclose(sol.x, ref.x, atol=1e-4)
    assert sol.cost <= ref.cost * (1 + 1e-7)
    assert_allclose(sol.jac, ref.jac, rtol=1e-3, atol=1e-5)  # both scaled by the loss, at x equal to 1e-4


def test_forward_jacobian_is_exact_on_a_linear_map() -> None:
    A = np.random.default_rng(1).normal(size=(6, 3))
    x = np.array([0.3, -2.0, 5.0])
    assert_allclose(forward_jacobian(lambda X: X @ A.T, x, A @ x), A, atol=1e-6)


def test_non_finite_residuals_end_within_the_budget() -> None:
    sol = levenberg_marquardt(lambda X: np.full((len(X), 3), np.nan), np.zeros(2), np.ones(2), max_nfev=10)
    assert not sol.success and sol.nfev <= 10


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("loss", ["linear", "soft_l1", "cauchy"])
def test_named_losses_with_jacobian_scaling_match_scipy(seed: int, loss: str) -> None:
    """The shape fits' settings: scipy's named losses in units of f_scale, x_scale="jac", a given Jacobian."""
    rng = np.random.default_rng(10 + seed)
    t = np.linspace(0.0, 4.0, 25)
    y = _exponentials(np.array([[1.5, 0.8, -0.2]]), t, 0.0)[0] + rng.normal(0, 0.05, t.size)
    y[rng.choice(t.size, 2, replace=False)] -= 0.8

    def jac(x: np.ndarray) -> np.ndarray:
        e = np.exp(-x[1] * t)
        return np.stack([e, -x[0] * t * e, np.ones_like(t)], axis=1)

    x0 = np.array([0.5, 2.0, 0.5])
    sol = levenberg_marquardt(lambda X: _exponentials(X, t, y), x0, "jac", loss=named_loss(loss, 0.1), jac=jac)
    ref = least_squares(lambda x: _exponentials(x[None], t, y)[0], x0, jac=jac, loss=loss, f_scale=0.1, x_scale="jac")
    assert sol.success
    assert_allclose(sol.x, ref.x, atol=1e-4)
    assert_allclose(sol.cost, ref.cost, rtol=1e-6)
    assert_allclose(sol.fun, _exponentials(sol.x[None], t, y)[0], rtol=0, atol=0)


def test_named_loss_rejects_an_unknown_name() -> None:
    with pytest.raises(ValueError, match="loss: got 'huber'"):
        named_loss("huber")
    with pytest.raises(ValueError, match="x_scale: got 'auto'"):
        levenberg_marquardt(lambda X: X, np.zeros(2), "auto")


@pytest.mark.parametrize("seed", range(20))
def test_trust_region_step_is_the_constrained_minimiser(seed: int) -> None:
    """Inside the region: the Newton step; else a step of the region's length that no other step of at most that
    length beats (checked against many random ones), with a multiplier >= 0 (H + lam I) s = -g."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(4, 4))
    eigenvalues = np.sort(rng.uniform(-1.0, 3.0, 4)) if seed % 2 else np.sort(rng.uniform(0.1, 3.0, 4))
    g = rng.normal(size=4)
    radius = float(rng.uniform(0.1, 3.0))
    s = trust_region_step(eigenvalues, g, radius)
    model = lambda v: g @ v + 0.5 * v @ (eigenvalues * v)  # noqa: E731
    assert np.linalg.norm(s) <= radius * (1 + 1e-3)
    newton = -g / eigenvalues
    if eigenvalues[0] > 0 and np.linalg.norm(newton) <= radius:
        assert_allclose(s, newton)
    else:
        assert_allclose(np.linalg.norm(s), radius, rtol=2e-3)
        lam = -(g + eigenvalues * s) / s
        assert_allclose(lam, lam[0], rtol=1e-6)
        assert lam[0] >= -1e-9
    others = rng.normal(size=(2000, 4)) @ np.linalg.qr(A)[0]
    others *= (radius * rng.uniform(0, 1, (2000, 1)) ** 0.25) / np.linalg.norm(others, axis=1, keepdims=True)
    assert model(s) <= min(model(v) for v in others) + 1e-9
