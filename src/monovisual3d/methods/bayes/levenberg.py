"""A small robust Levenberg-Marquardt solver for the few-parameter fits of one object.

:func:`scipy.optimize.least_squares` is the reference: the same cost (``0.5 sum rho(f^2)``), the same scaling of
residuals and Jacobian by a robust loss (Triggs' correction, as scipy applies it), the same forward-difference
steps and the same tolerances. What differs is the step control (a damped Gauss-Newton step in variables scaled by
``x_scale`` instead of scipy's trust-region reflective step) and the overhead: a sphere's refinement takes about a
dozen evaluations of a few dozen residuals, so scipy's per-call and per-iteration bookkeeping (argument checks, an
SVD per step, norms) costs several times the residuals themselves; on a 96-fruit plant row the refinements run
some 200 times per localisation. Here the residuals are evaluated in batches (the point and its four or five
difference steps in one call), and the damped normal equations are solved directly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Batched residuals: parameter vectors (P, k) -> residuals (P, n).
BatchResiduals = Callable[[NDArray[np.float64]], NDArray[np.float64]]
#: A robust loss of squared residuals z (n,) -> (3, n): rho, rho', rho'' (scipy's convention).
Loss = Callable[[NDArray[np.float64]], NDArray[np.float64]]

#: scipy's relative step for ``jac="2-point"``: sqrt of the float64 machine epsilon.
FD_REL_STEP = float(np.sqrt(np.finfo(float).eps))
#: scipy's default tolerances on the cost's change, the step and the gradient.
FTOL = XTOL = GTOL = 1e-8
#: Initial damping relative to the largest diagonal of the scaled Gauss-Newton Hessian (nearly a Gauss-Newton
#: step, as scipy's first trust region, the size of ``x0`` itself, is for these fits).
INITIAL_DAMPING = 1e-3
#: A step must reduce the cost by at least this fraction of its predicted reduction for the solver to stop on
#: the cost tolerance (scipy's rule).
FTOL_MIN_RATIO = 0.25


@dataclass(frozen=True)
class Solution:
    """What :func:`levenberg_marquardt` returns.

    Attributes
    ----------
    x : ndarray, shape (k,), the parameters at the minimum
    cost : float, ``0.5 sum rho(f^2)`` there (``0.5 |f|^2`` without a loss)
    jac : ndarray, shape (n, k), the forward-difference Jacobian there, scaled by the loss as scipy returns it
        (``jac.T @ jac`` is the Gauss-Newton Hessian of the cost)
    success : bool, a tolerance was met (False: the evaluation budget ran out first)
    nfev : int, residual evaluations at trial points (the difference steps not counted, as in scipy)
    """

    x: NDArray[np.float64]
    cost: float
    jac: NDArray[np.float64]
    success: bool
    nfev: int


def forward_jacobian(batch: BatchResiduals, x: NDArray[np.float64], f: NDArray[np.float64]) -> NDArray[np.float64]:
    """Forward-difference Jacobian (n, k) at ``x`` (k,) with residuals ``f`` (n,) there, scipy's ``2-point`` steps,
    in one batched call."""
    h = FD_REL_STEP * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
    h = (x + h) - x  # the step actually taken in floating point
    return ((batch(x + np.diag(h)) - f) / h[:, None]).T


def scaled_by_loss(
    loss: Loss | None, f: NDArray[np.float64], J: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """The cost at residuals ``f`` (n,) and the residuals and Jacobian (n, k) scaled so that ordinary least squares
    on them takes the robust loss's Gauss-Newton step (scipy's ``scale_for_robust_loss_function``)."""
    if loss is None:
        return 0.5 * float(f @ f), f, J
    rho = loss(f * f)
    w = np.sqrt(np.maximum(rho[1] + 2.0 * rho[2] * f * f, np.finfo(float).eps))
    return 0.5 * float(np.sum(rho[0])), f * rho[1] / w, J * w[:, None]


def _cost(loss: Loss | None, f: NDArray[np.float64]) -> float:
    return 0.5 * float(f @ f) if loss is None else 0.5 * float(np.sum(loss(f * f)[0]))


def levenberg_marquardt(
    batch: BatchResiduals,
    x0: NDArray[np.floating],
    x_scale: NDArray[np.floating],
    *,
    loss: Loss | None = None,
    max_nfev: int = 100,
) -> Solution:
    """Minimise ``0.5 sum rho(f(x)^2)`` from ``x0`` (k,) with damped Gauss-Newton steps.

    Parameters
    ----------
    batch : residuals of several parameter vectors at once, (P, k) -> (P, n)
    x0 : ndarray, shape (k,), the start
    x_scale : ndarray, shape (k,), the size of a meaningful change of each parameter (the damping is isotropic in
        ``x / x_scale``)
    loss : the robust loss (see :data:`Loss`), or None for plain least squares
    max_nfev : int, most evaluations at trial points

    Examples
    --------
    >>> import numpy as np
    >>> sol = levenberg_marquardt(lambda X: X - np.array([1.0, 2.0]), np.zeros(2), np.ones(2))
    >>> np.allclose(sol.x, [1.0, 2.0]), sol.success
    (True, True)
    """
    x = np.array(x0, dtype=float)
    scale = np.asarray(x_scale, dtype=float)
    f = batch(x[None])[0]
    nfev, converged = 1, False
    J = forward_jacobian(batch, x, f)
    damping, grow = None, 2.0
    while not converged and nfev < max_nfev:
        cost, fs, Js = scaled_by_loss(loss, f, J)
        g = Js.T @ fs
        if np.max(np.abs(g)) < GTOL:
            converged = True
            break
        Jsc = Js * scale
        H, gsc = Jsc.T @ Jsc, g * scale
        if damping is None:
            damping = INITIAL_DAMPING * max(float(np.max(np.diag(H))), 1.0)
        accepted = False
        while not accepted and nfev < max_nfev:
            try:
                step = np.linalg.solve(H + damping * np.eye(len(x)), -gsc)
            except np.linalg.LinAlgError:  # not finite: counted as a failed evaluation, so the loop ends
                damping, grow, nfev = damping * grow, grow * 2.0, nfev + 1
                continue
            dx = step * scale
            x_new = x + dx
            f_new = batch(x_new[None])[0]
            nfev += 1
            predicted = -float(gsc @ step + 0.5 * step @ H @ step)
            actual = cost - _cost(loss, f_new) if np.all(np.isfinite(f_new)) else -np.inf
            ratio = actual / predicted if predicted > 0 else -1.0
            small_step = float(np.linalg.norm(dx)) < XTOL * (XTOL + float(np.linalg.norm(x)))
            if actual > 0 and ratio > 0:
                accepted = True
                damping *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
                grow = 2.0
                converged = small_step or (actual < FTOL * cost and ratio > FTOL_MIN_RATIO)
                x, f = x_new, f_new
                J = forward_jacobian(batch, x, f)
            else:
                damping, grow = damping * grow, grow * 2.0
                if small_step:
                    converged = True
                    break
    cost, _, Js = scaled_by_loss(loss, f, J)
    return Solution(x, cost, Js, converged, nfev)
