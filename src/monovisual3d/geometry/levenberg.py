"""A small robust Levenberg-Marquardt solver for the few-parameter fits of one object (a sphere's refinement, a
shape's fit to its boxes).

:func:`scipy.optimize.least_squares` (method ``trf``) is the reference: the same cost (``0.5 sum rho(f^2)``), the
same scaling of residuals and Jacobian by a robust loss (Triggs' correction, as scipy applies it), the same
forward-difference steps, tolerances and step control (a trust region in variables scaled by ``x_scale``, the
region's update rule; the step is the exact minimiser in the region, Moré's form of Levenberg-Marquardt). What
differs is the overhead: a sphere's refinement takes about a dozen evaluations of a few dozen residuals, and scipy's
per-call and per-step bookkeeping (argument checks, an SVD of the Jacobian per step, norms) costs several times the
residuals themselves; on a 96-fruit plant row the refinements run some 200 times per localisation, and a shape fit
to two containers' boxes several dozen times. Here the residuals are evaluated in batches (a point and its
difference steps in one call), and each step is solved in the k x k eigenbasis of the Gauss-Newton Hessian.
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
#: fraction of the step; above the next ratio a step on its boundary (within this fraction) doubles it.
SHRINK_BELOW_RATIO, SHRINK_FACTOR = 0.25, 0.25
GROW_ABOVE_RATIO, ON_BOUNDARY = 0.75, 0.95
#: Newton iterations on the step length of :func:`trust_region_step` (it converges in a handful).
TRUST_REGION_ITERATIONS = 30
#: scipy's ``max_nfev`` default for its trust-region method: this many evaluations per parameter.
NFEV_PER_PARAMETER = 100


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
    nfev : int, residual evaluations at trial points (the difference steps not counted, as in scipy)
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
    """scipy's robust loss ``name`` (``linear``, ``soft_l1``, ``cauchy``) of residuals in units of ``f_scale``, as a
    :data:`Loss` (None for ``linear``): ``C^2 rho(z / C^2)`` with ``C = f_scale``, as scipy scales it."""
    c2 = float(f_scale) ** 2
    if name == "linear":
        return None
    if name not in ("soft_l1", "cauchy"):
        raise ValueError(f"loss: got {name!r}, expected 'linear', 'soft_l1' or 'cauchy'")

    def rho(z: NDArray[np.float64]) -> NDArray[np.float64]:
        t = 1.0 + z / c2
        out = np.empty((3, len(z)))
        if name == "soft_l1":
            out[0], out[1], out[2] = 2.0 * (np.sqrt(t) - 1.0) * c2, t**-0.5, -0.5 * t**-1.5 / c2
        else:
            out[0], out[1], out[2] = np.log1p(z / c2) * c2, 1.0 / t, -1.0 / (t * t) / c2
        return out

    return rho


def trust_region_step(eigenvalues: NDArray[np.float64], g: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    """The minimiser of ``g.s + s.H.s / 2`` with ``|s| <= radius``, in the eigenbasis of ``H`` (eigenvalues (k,),
    ``g`` (k,) there): the Gauss-Newton step when it fits, else ``-g / (eigenvalues + lam)`` with ``lam`` set so that
    the step has length ``radius`` (Moré and Sorensen's Newton iteration on ``1 / |s|``)."""
    lam_min = max(0.0, -float(eigenvalues[0]))
    tiny = np.finfo(float).eps * max(float(eigenvalues[-1]), 1.0)
    if eigenvalues[0] > tiny:
        s = -g / eigenvalues
        if np.linalg.norm(s) <= radius:
            return s
    lam = lam_min + tiny
    for _ in range(TRUST_REGION_ITERATIONS):
        d = eigenvalues + lam
        s = -g / d
        norm = float(np.linalg.norm(s))
        if not norm > 0 or abs(norm - radius) <= 1e-3 * radius:
            break
        # phi(lam) = 1/|s| - 1/radius is nearly linear in lam: Newton's step on it
        dnorm = -float(np.sum(g * g / d**3)) / norm
        lam = max(lam - (norm - radius) / radius * norm / dnorm, lam_min + tiny) if dnorm < 0 else lam * 2.0
    return -g / (eigenvalues + lam)


class _Region:
    """The quadratic model of one iteration (scaled Gauss-Newton Hessian ``H`` (k, k), gradient ``g`` (k,), the
    cost there) and its trust region, shrunk or grown after each trial step by scipy's rule."""

    def __init__(self, H: NDArray[np.float64], g: NDArray[np.float64], scale: NDArray[np.float64], cost: float, radius: float):
        self.H, self.g, self.scale, self.cost, self.radius = H, g, scale, cost, radius
        self.eigenvalues, self.Q = np.linalg.eigh(H)
        self.g_eigen = self.Q.T @ g

    def trial(
        self, batch: BatchResiduals, loss: Loss | None, x: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, bool]:
        """One trial step from ``x``: the new point, its residuals (None: rejected, the region shrunk) and whether a
        tolerance is met."""
        step = self.Q @ trust_region_step(self.eigenvalues, self.g_eigen, self.radius)
        step_norm = float(np.linalg.norm(step))
        dx = step * self.scale
        f_new = batch((x + dx)[None])[0]
        predicted = -float(self.g @ step + 0.5 * step @ self.H @ step)
        actual = self.cost - _cost(loss, f_new) if np.all(np.isfinite(f_new)) else -np.inf
        ratio = actual / predicted if predicted > 0 else 0.0
        if ratio < SHRINK_BELOW_RATIO:
            self.radius = SHRINK_FACTOR * step_norm
        elif ratio > GROW_ABOVE_RATIO and step_norm >= ON_BOUNDARY * self.radius:
            self.radius *= 2.0
        converged = (actual < FTOL * self.cost and ratio > SHRINK_BELOW_RATIO) or (
            float(np.linalg.norm(dx)) < XTOL * (XTOL + float(np.linalg.norm(x)))
        )
        return x + dx, (f_new if actual > 0 else None), converged


def _cost(loss: Loss | None, f: NDArray[np.float64]) -> float:
    return 0.5 * float(f @ f) if loss is None else 0.5 * float(np.sum(loss(f * f)[0]))


def levenberg_marquardt(
    batch: BatchResiduals,
    x0: NDArray[np.floating],
    x_scale: NDArray[np.floating] | str,
    *,
    loss: Loss | None = None,
    max_nfev: int | None = None,
    jac: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
) -> Solution:
    """Minimise ``0.5 sum rho(f(x)^2)`` from ``x0`` (k,) with Gauss-Newton steps in a trust region.

    Parameters
    ----------
    batch : residuals of several parameter vectors at once, (P, k) -> (P, n)
    x0 : ndarray, shape (k,), the start
    x_scale : ndarray, shape (k,), the size of a meaningful change of each parameter (the trust region is a ball in
        ``x / x_scale``); ``"jac"``: the inverse of the largest norm each Jacobian column has had (scipy's rule)
    loss : the robust loss (see :data:`Loss`, :func:`named_loss`), or None for plain least squares
    max_nfev : int, most evaluations at trial points (default: scipy's, 100 per parameter)
    jac : the Jacobian (n, k) at a parameter vector (k,); default: :func:`forward_jacobian` of ``batch``

    Examples
    --------
    >>> import numpy as np
    >>> sol = levenberg_marquardt(lambda X: X - np.array([1.0, 2.0]), np.zeros(2), np.ones(2))
    >>> np.allclose(sol.x, [1.0, 2.0]), sol.success
    (True, True)
    """
    x = np.array(x0, dtype=float)
    if isinstance(x_scale, str) and x_scale != "jac":
        raise ValueError(f"x_scale: got {x_scale!r}, expected 'jac' or an array")
    jac_scale = isinstance(x_scale, str)
    max_nfev = NFEV_PER_PARAMETER * len(x) if max_nfev is None else max_nfev
    jacobian = (lambda x, f: forward_jacobian(batch, x, f)) if jac is None else (lambda x, f: jac(x))
    f, nfev, converged, column_norm, radius = batch(x[None])[0], 1, False, np.zeros(len(x)), None
    J = jacobian(x, f)
    while not converged and nfev < max_nfev:
        cost, fs, Js = scaled_by_loss(loss, f, J)
        if jac_scale:  # scipy's rule: the inverse of the largest norm each column has had
            column_norm = np.maximum(column_norm, np.linalg.norm(Js, axis=0))
        scale = np.asarray(x_scale, dtype=float) if not jac_scale else 1.0 / np.where(column_norm > 0, column_norm, 1.0)
        if radius is None:  # scipy's first trust region: the size of x0 itself, in scaled variables
            radius = float(np.linalg.norm(x / scale)) or 1.0
        g = Js.T @ fs
        converged = bool(np.max(np.abs(g)) < GTOL)
        if converged or not np.all(np.isfinite(g)):
            break
        Jsc = Js * scale
        region = _Region(Jsc.T @ Jsc, g * scale, scale, cost, radius)
        while nfev < max_nfev:
            x_new, f_new, converged = region.trial(batch, loss, x)
            nfev, radius = nfev + 1, region.radius
            if f_new is not None:
                x, f = x_new, f_new
                J = jacobian(x, f)
                break
            if converged:
                break
    cost, _, Js = scaled_by_loss(loss, f, J)
    return Solution(x, f, cost, Js, converged, nfev)
