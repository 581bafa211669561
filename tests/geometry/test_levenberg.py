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


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("loss", ["linear", "soft_l1", "huber", "cauchy", "arctan"])
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
    assert sol.success and ref.success
    assert sol.nfev == ref.nfev  # the same steps
    assert_allclose(sol.x, ref.x, atol=1e-6)
    assert_allclose(sol.cost, ref.cost, rtol=1e-9)
    assert_allclose(sol.fun, _exponentials(sol.x[None], t, y)[0], rtol=0, atol=0)


def test_named_loss_rejects_an_unknown_name() -> None:
    with pytest.raises(ValueError, match="loss: got 'l2'"):
        named_loss("l2")
    with pytest.raises(ValueError, match="x_scale: got 'auto'"):
        levenberg_marquardt(lambda X: X, np.zeros(2), "auto")


@pytest.mark.parametrize("seed", range(20))
def test_trust_region_step_is_the_constrained_minimiser(seed: int) -> None:
    """Inside the region: the Gauss-Newton step; else a step on the boundary that no other step of at most that
    length beats by more than the length tolerance allows (checked against many random ones)."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(12, 4)) * ([1.0, 1.0, 1.0, 1e-9] if seed % 3 == 0 else 1.0)  # some rank-deficient
    eigenvalues, Q = np.linalg.eigh(J.T @ J)
    g = Q.T @ (J.T @ rng.normal(size=12))
    radius = float(rng.uniform(0.05, 3.0))
    s, alpha = trust_region_step(eigenvalues, g, radius, 12, 0.0)
    model = lambda v: g @ v + 0.5 * v @ (eigenvalues * v)  # noqa: E731
    newton = -g / eigenvalues
    if seed % 3 and np.linalg.norm(newton) <= radius:
        assert_allclose(s, newton)
        assert alpha == 0.0
    else:
        assert_allclose(np.linalg.norm(s), radius, rtol=1e-12)
        assert alpha > 0
    others = rng.normal(size=(4000, 4))
    others *= radius * rng.uniform(0, 1, (4000, 1)) ** 0.25 / np.linalg.norm(others, axis=1, keepdims=True)
    best_other = min(model(v) for v in others)
    assert model(s) <= best_other + 0.02 * abs(best_other)


def test_non_finite_trial_residuals_shrink_the_region() -> None:
    """A trial point where the residuals are not finite (a size's exp overflowing, say) is rejected and the region
    shrinks, as in scipy: from a start whose first step lands there, the solver still reaches the minimum."""

    def batch(X: np.ndarray) -> np.ndarray:  # roots at 0.3; the first step, to the origin, lands where it is NaN
        return np.where(X.sum(axis=1, keepdims=True) > 0.2, np.tanh(X) - np.tanh(0.3), np.nan)

    x0 = np.array([2.0, 2.0])
    sol = levenberg_marquardt(batch, x0, np.ones(2))
    ref = least_squares(lambda x: batch(x[None])[0], x0, x_scale=np.ones(2))
    assert not np.all(np.isfinite(batch(x0[None] - [[2.0, 2.0]])))
    assert sol.success and ref.success
    assert_allclose(sol.x, [0.3, 0.3], atol=1e-8)
    assert sol.nfev == ref.nfev


def test_budget_runs_out_as_in_scipy() -> None:
    def rosenbrock(X: np.ndarray) -> np.ndarray:
        return np.stack([10.0 * (X[:, 1] - X[:, 0] ** 2), 1.0 - X[:, 0]], axis=1)

    x0 = np.array([-1.2, 1.0])
    sol = levenberg_marquardt(rosenbrock, x0, np.ones(2), max_nfev=5)
    ref = least_squares(lambda x: rosenbrock(x[None])[0], x0, x_scale=np.ones(2), max_nfev=5)
    assert not sol.success and ref.status == 0
    assert sol.nfev == ref.nfev == 5
    assert_allclose(sol.x, ref.x, rtol=1e-6)


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(ValueError, match="x0: the residuals are not finite"):
        levenberg_marquardt(lambda X: np.full((len(X), 3), np.nan), np.zeros(2), np.ones(2))
    with pytest.raises(ValueError, match="x_scale"):
        levenberg_marquardt(lambda X: X, np.zeros(2), np.array([1.0, 0.0]))
    with pytest.raises(ValueError, match="max_nfev"):
        levenberg_marquardt(lambda X: X, np.zeros(2), np.ones(2), max_nfev=0)
