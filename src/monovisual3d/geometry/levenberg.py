"""A small robust Levenberg-Marquardt solver for the few-parameter fits of one object (a sphere's refinement, a
shape's fit to its boxes).

It is :func:`scipy.optimize.least_squares` (method ``trf``, exact trust-region solver, no bounds) step by step: the
same cost (``0.5 sum rho(f^2)``), the same scaling of residuals and Jacobian by a robust loss (Triggs' correction, as
scipy applies it), forward-difference steps, tolerances, ``x_scale="jac"`` rule, trust region (the step is the exact
minimiser in the region found by Moré's iteration on the Levenberg-Marquardt parameter, carried from step to step) and
region update. Only the linear algebra differs: each step is solved in the eigenbasis of the k x k Gauss-Newton
Hessian ``J^T J`` instead of an SVD of ``J``, so the iterates agree with scipy's to rounding (tested). What it saves is
the overhead: a sphere's refinement takes about a dozen evaluations of a few dozen residuals, and scipy's per-call and
per-step bookkeeping (argument checks, an SVD per step, norms) costs several times the residuals themselves; on a
96-fruit plant row the refinements run some 200 times per localisation, and a shape fit to two containers' boxes
several dozen times. Here the residuals of a point and its difference steps come from one batched call.
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
#: scipy's trust-region rule: below this ratio of actual to predicted reduction the region shrinks to this
#: fraction of the step; above the next ratio a step on its boundary (beyond this fraction of it) grows it by the
#: next factor.
SHRINK_BELOW_RATIO, SHRINK_FACTOR = 0.25, 0.25
GROW_ABOVE_RATIO, ON_BOUNDARY, GROW_FACTOR = 0.75, 0.95, 2.0
#: scipy's iteration on the Levenberg-Marquardt parameter: relative tolerance on the step's length, most iterations,
#: and the fraction of its upper bound where a guess outside its bracket restarts.
STEP_LENGTH_RTOL, STEP_ITERATIONS, RESTART_FRACTION = 0.01, 10, 0.001
#: scipy's ``max_nfev`` default for its trust-region method: this many evaluations per parameter.
NFEV_PER_PARAMETER = 100
#: float64 machine epsilon (scipy's rank threshold is this times the residuals times the largest singular value).
EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class Solution:
    """What :func:`levenberg_marquardt` returns.

    Attributes
    ----------
    x : ndarray, shape (k,), the parameters at the minimum
    cost : float, ``0.5 sum rho(f^2)`` there (``0.5 |f|^2`` without a loss)
    fun : ndarray, shape (n,), the residuals there
    jac : ndarray, shape (n, k), the Jacobian there, scaled by the loss as scipy returns it
        (``jac.T @ jac`` is the Gauss-Newton Hessian of the cost)
    success : bool, a tolerance was met (False: the evaluation budget ran out first)
    nfev : int, residual evaluations at ``x0`` and at trial points (the difference steps not counted, as in scipy)
    """

    x: NDArray[np.float64]
    fun: NDArray[np.float64]
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


def named_loss(name: str, f_scale: float = 1.0) -> Loss | None:
    """scipy's robust loss ``name`` (:data:`LOSSES`) of residuals in units of ``f_scale``, as a :data:`Loss` (None for
    ``linear``): ``C^2 rho(z / C^2)`` with ``C = f_scale``, as scipy scales it."""
    if name not in LOSSES:
        raise ValueError(f"loss: got {name!r}, expected one of {', '.join(LOSSES)}")
    if name == "linear":
        return None
    c2 = float(f_scale) ** 2
    unit = _UNIT_LOSSES[name]

    def rho(z: NDArray[np.float64]) -> NDArray[np.float64]:
        out = unit(np.asarray(z, dtype=float) / c2)
        out[0] *= c2
        out[2] /= c2
        return out

    return rho


def _soft_l1(z: NDArray[np.float64]) -> NDArray[np.float64]:
    t = 1.0 + z
    return np.stack([2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5])


def _huber(z: NDArray[np.float64]) -> NDArray[np.float64]:
    far = z > 1.0
    root = np.sqrt(np.where(far, z, 1.0))
    return np.stack([np.where(far, 2.0 * root - 1.0, z), np.where(far, 1.0 / root, 1.0), np.where(far, -0.5 / root**3, 0.0)])


def _cauchy(z: NDArray[np.float64]) -> NDArray[np.float64]:
    t = 1.0 + z
    return np.stack([np.log1p(z), 1.0 / t, -1.0 / t**2])


def _arctan(z: NDArray[np.float64]) -> NDArray[np.float64]:
    t = 1.0 + z**2
    return np.stack([np.arctan(z), 1.0 / t, -2.0 * z / t**2])


#: scipy's robust losses of a squared residual in units of ``f_scale``: rho, rho', rho'' (3, n).
_UNIT_LOSSES: dict[str, Callable[[NDArray[np.float64]], NDArray[np.float64]]] = {
    "soft_l1": _soft_l1,
    "huber": _huber,
    "cauchy": _cauchy,
    "arctan": _arctan,
}
#: The names :func:`named_loss` takes (scipy's).
LOSSES = ("linear", *_UNIT_LOSSES)


def trust_region_step(
    eigenvalues: NDArray[np.float64], g: NDArray[np.float64], radius: float, n_residuals: int, alpha0: float
) -> tuple[NDArray[np.float64], float]:
    """The minimiser of ``g.s + s.H.s / 2`` with ``|s| <= radius`` for ``H = J^T J`` of ``n_residuals`` rows, in the
    eigenbasis of ``H`` (its eigenvalues (k,), ascending, and ``g`` (k,) there), and the Levenberg-Marquardt parameter
    ``alpha`` of the step: scipy's ``solve_lsq_trust_region`` with the singular values of ``J`` as the roots of the
    eigenvalues. The Gauss-Newton step when ``J`` has full rank and the step fits; else ``-g / (eigenvalues + alpha)``
    scaled onto the boundary, ``alpha`` from Moré's safeguarded Newton iteration started at ``alpha0`` (the last
    step's)."""
    sv2 = np.maximum(eigenvalues, 0.0)
    sv = np.sqrt(sv2)
    full_rank = n_residuals >= len(sv) and sv[0] > EPS * n_residuals * sv[-1]
    if full_rank:
        step = -g / sv2
        if np.linalg.norm(step) <= radius:
            return step, 0.0

    def phi_and_derivative(alpha: float) -> tuple[float, float]:
        denominator = sv2 + alpha
        norm = float(np.linalg.norm(g / denominator))
        return norm - radius, -float(np.sum(g**2 / denominator**3)) / norm

    upper = float(np.linalg.norm(g)) / radius
    lower = 0.0
    if full_rank:
        phi, derivative = phi_and_derivative(0.0)
        lower = -phi / derivative
    restart = max(RESTART_FRACTION * upper, (lower * upper) ** 0.5)
    alpha = restart if not full_rank and alpha0 == 0 else alpha0
    for _ in range(STEP_ITERATIONS):
        if alpha < lower or alpha > upper:
            alpha = max(RESTART_FRACTION * upper, (lower * upper) ** 0.5)
        phi, derivative = phi_and_derivative(alpha)
        if phi < 0:
            upper = alpha
        newton = phi / derivative
        lower = max(lower, alpha - newton)
        alpha -= (phi + radius) * newton / radius
        if abs(phi) < STEP_LENGTH_RTOL * radius:
            break
    step = -g / (sv2 + alpha)
    return step * (radius / np.linalg.norm(step)), alpha


def updated_radius(radius: float, actual: float, predicted: float, step_norm: float) -> tuple[float, float]:
    """scipy's update of the trust region's radius after a step of length ``step_norm`` (scaled variables) that
    reduced the cost by ``actual`` where the model predicted ``predicted``; returns the radius and the ratio."""
    if predicted > 0:
        ratio = actual / predicted
    else:
        ratio = 1.0 if predicted == actual == 0 else 0.0
    if ratio < SHRINK_BELOW_RATIO:
        return SHRINK_FACTOR * step_norm, ratio
    if ratio > GROW_ABOVE_RATIO and step_norm > ON_BOUNDARY * radius:
        return GROW_FACTOR * radius, ratio
    return radius, ratio


def converged(actual: float, cost: float, step_norm: float, x_norm: float, ratio: float) -> bool:
    """scipy's tests on a step: the cost changed by less than :data:`FTOL` of itself (on a step the model
    predicted well), or the step (unscaled) is below :data:`XTOL` of ``x``."""
    return (actual < FTOL * cost and ratio > SHRINK_BELOW_RATIO) or step_norm < XTOL * (XTOL + x_norm)


def _cost(loss: Loss | None, f: NDArray[np.float64]) -> float:
    return 0.5 * float(f @ f) if loss is None else 0.5 * float(np.sum(loss(f * f)[0]))


def _column_norms(J: NDArray[np.float64], old: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """scipy's ``x_scale="jac"``: the inverse scale of each parameter, the largest norm its column has had
    (a column of zeros at the start counts as 1)."""
    norms = np.linalg.norm(J, axis=0)
    return np.where(norms == 0, 1.0, norms) if old is None else np.maximum(norms, old)


@dataclass
class _Iterate:
    """The solver's state: the point, its residuals and Jacobian, the region, the Levenberg-Marquardt parameter."""

    x: NDArray[np.float64]
    f: NDArray[np.float64]
    J: NDArray[np.float64]
    radius: float
    alpha: float = 0.0
    nfev: int = 1
    converged: bool = False


def _trial_steps(
    it: _Iterate,
    batch: BatchResiduals,
    loss: Loss | None,
    H: NDArray[np.float64],
    g: NDArray[np.float64],
    scale: NDArray[np.float64],
    max_nfev: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """Steps from ``it.x`` under the model ``H`` (k, k), ``g`` (k,) in scaled variables until one lowers the cost,
    a tolerance is met or the budget runs out (scipy's inner loop); returns the new point and its residuals, or None.
    Updates the region, the parameter, the count and ``converged`` of ``it``."""
    cost = _cost(loss, it.f)
    eigenvalues, Q = np.linalg.eigh(H)
    g_eigen = Q.T @ g
    while it.nfev < max_nfev:
        step_eigen, it.alpha = trust_region_step(eigenvalues, g_eigen, it.radius, len(it.f), it.alpha)
        step = Q @ step_eigen
        step_norm = float(np.linalg.norm(step_eigen))
        x_new = it.x + step * scale
        f_new = batch(x_new[None])[0]
        it.nfev += 1
        if not np.all(np.isfinite(f_new)):
            it.radius = SHRINK_FACTOR * step_norm
            continue
        actual = cost - _cost(loss, f_new)
        radius, ratio = updated_radius(it.radius, actual, -float(g @ step + 0.5 * step @ H @ step), step_norm)
        it.converged = converged(actual, cost, float(np.linalg.norm(step * scale)), float(np.linalg.norm(it.x)), ratio)
        if not it.converged:
            it.alpha *= it.radius / radius
            it.radius = radius
        if actual > 0:
            return x_new, f_new
        if it.converged:
            return None
    return None


def levenberg_marquardt(
    batch: BatchResiduals,
    x0: NDArray[np.floating],
    x_scale: NDArray[np.floating] | str,
    *,
    loss: Loss | None = None,
    max_nfev: int | None = None,
    jac: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
) -> Solution:
    """Minimise ``0.5 sum rho(f(x)^2)`` from ``x0`` (k,): scipy's ``least_squares(method="trf")`` without bounds.

    Parameters
    ----------
    batch : residuals of several parameter vectors at once, (P, k) -> (P, n)
    x0 : ndarray, shape (k,), the start (its residuals must be finite)
    x_scale : ndarray, shape (k,), positive, the size of a meaningful change of each parameter (the trust region is a
        ball in ``x / x_scale``); ``"jac"``: the inverse of the largest norm each Jacobian column has had
    loss : the robust loss (see :data:`Loss`, :func:`named_loss`), or None for plain least squares
    max_nfev : int, most evaluations (default: scipy's, 100 per parameter)
    jac : the Jacobian (n, k) at a parameter vector (k,); default: :func:`forward_jacobian` of ``batch``

    Examples
    --------
    >>> import numpy as np
    >>> sol = levenberg_marquardt(lambda X: X - np.array([1.0, 2.0]), np.zeros(2), np.ones(2))
    >>> np.allclose(sol.x, [1.0, 2.0]), sol.success
    (True, True)
    """
    x = np.array(x0, dtype=float)
    scale, max_nfev = _checked(x, x_scale, max_nfev)
    jacobian = (lambda x, f: forward_jacobian(batch, x, f)) if jac is None else (lambda x, f: jac(x))
    f = batch(x[None])[0]
    if not np.all(np.isfinite(f)):
        raise ValueError("x0: the residuals are not finite there")
    it = _Iterate(x, f, jacobian(x, f), radius=0.0)
    column_norms = None
    while True:
        _, fs, Js = scaled_by_loss(loss, it.f, it.J)
        if scale is None:  # at the start and after each accepted step, as scipy updates it
            column_norms = _column_norms(Js, column_norms)
        d = 1.0 / column_norms if scale is None else scale
        if it.nfev == 1:  # scipy's first region: the size of x0 in scaled variables
            it.radius = float(np.linalg.norm(it.x / d)) or 1.0
        g = Js.T @ fs
        it.converged = it.converged or bool(np.max(np.abs(g)) < GTOL)
        if it.converged or it.nfev >= max_nfev or not np.all(np.isfinite(g)):
            break
        Jd = Js * d
        new = _trial_steps(it, batch, loss, Jd.T @ Jd, g * d, d, max_nfev)
        if new is None:  # a tolerance met or the budget spent
            break
        it.x, it.f = new
        it.J = jacobian(it.x, it.f)
    cost, _, Js = scaled_by_loss(loss, it.f, it.J)
    return Solution(it.x, it.f, cost, Js, it.converged, it.nfev)


def _checked(
    x: NDArray[np.float64], x_scale: NDArray[np.floating] | str, max_nfev: int | None
) -> tuple[NDArray[np.float64] | None, int]:
    """The fixed scale (None for ``"jac"``) and the evaluation budget, checked."""
    if isinstance(x_scale, str):
        if x_scale != "jac":
            raise ValueError(f"x_scale: got {x_scale!r}, expected 'jac' or an array of positive numbers")
        scale = None
    else:
        scale = np.asarray(x_scale, dtype=float)
        if scale.shape != x.shape or not np.all(np.isfinite(scale) & (scale > 0)):
            raise ValueError(f"x_scale: got {x_scale!r}, expected 'jac' or {len(x)} positive numbers")
    max_nfev = NFEV_PER_PARAMETER * len(x) if max_nfev is None else int(max_nfev)
    if max_nfev < 1:
        raise ValueError(f"max_nfev: got {max_nfev}, expected at least 1")
    return scale, max_nfev
