"""Error metrics, with estimates matched to ground truth (Hungarian).

The paper's metrics (its Eqs. 10-13) average over the M objects and the N = 3
coordinates: ``MAE = mean |mu - mu_hat|``, ``MSE = mean (mu - mu_hat)^2``,
``RMSE = sqrt(MSE)`` and ``MAPE = 100 * mean |(mu - mu_hat) / mu|``; we add the
mean Euclidean error that the paper's testbed table reports. MAPE divides by
the true coordinate, so it depends on where the base frame's origin is; true
coordinates that are exactly zero are left out of its mean (they would make
it infinite).

Matching: estimates and truth are paired by minimum total distance
(:func:`scipy.optimize.linear_sum_assignment`). Error metrics use every pair,
however far apart (so a misplaced object shows up as a large error).
Detection counts use a gate: a pair farther apart than the gate (default:
the true radius, at least 20 mm; 50 mm when radii are unknown) counts as a
miss plus a false positive; unpaired truth objects are misses, unpaired
estimates false positives.

Shape errors (when semi-axes are given for truth and estimates): the semi-axes
of each matched pair are compared sorted (orientation-free: ``|sort(a_hat) -
sort(a)|`` per axis, averaged over the three axes and the pairs), and the
volume error is ``|V_hat - V|`` with ``V = 4/3 pi a b c`` (also as a percentage of ``V``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Smallest gate when radii are known, metres.
MIN_GATE_M = 0.02
#: Gate when radii are unknown, metres.
DEFAULT_GATE_M = 0.05


@dataclass
class Metrics:
    """Evaluation of one set of estimates against ground truth (metres, percent).

    Errors are over the Hungarian-matched pairs (see the module docstring); ``d_i`` is the 3D
    distance of pair ``i`` and ``e_ij`` its error along coordinate ``j`` (x, y, z).

    Attributes
    ----------
    n_truth, n_estimates : int, true objects and estimates
    n_matched : int, pairs formed by the matching (``min(n_truth, n_estimates)``)
    true_positives : int, pairs closer than the gate
    misses, false_positives : int, true objects and estimates not in a pair within the gate
    recall : float, ``true_positives / n_truth`` (NaN without truth)
    precision : float, ``true_positives / n_estimates`` (NaN without estimates)
    euclidean_mean, euclidean_median, euclidean_max : float, metres, of the 3D distances ``d_i``
    mae : float, metres, ``mean |e_ij|`` over all pairs **and coordinates** (the paper's Eq. 10)
    mse : float, m^2, ``mean e_ij^2`` over pairs and coordinates (Eq. 11)
    rmse : float, metres, ``sqrt(mse) = sqrt(mean d_i^2 / 3)``: per coordinate, hence usually below
        ``euclidean_mean`` (Eq. 12)
    mape : float, percent, ``100 mean |e_ij / mu_ij|`` over the non-zero true coordinates ``mu_ij`` (Eq. 13)
    radius_error_mean : float or None, metres, mean ``|r_hat - r|`` of the pairs with both radii
    semi_axis_error_mean, semi_axis_error_max : float or None, metres, ``|sort(a_hat) - sort(a)|`` per axis
    volume_error_mean : float or None, m^3, mean ``|V_hat - V|``, ``V = 4/3 pi a b c``
    volume_error_pct_mean : float or None, percent, mean ``100 |V_hat - V| / V``
    """

    n_truth: int
    n_estimates: int
    n_matched: int
    true_positives: int
    misses: int
    false_positives: int
    recall: float
    precision: float
    euclidean_mean: float
    euclidean_median: float
    euclidean_max: float
    mae: float
    mse: float
    rmse: float
    mape: float
    radius_error_mean: float | None = None
    semi_axis_error_mean: float | None = None
    semi_axis_error_max: float | None = None
    volume_error_mean: float | None = None
    volume_error_pct_mean: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def match(estimates: ArrayLike, truth: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Hungarian matching by Euclidean distance.

    Parameters
    ----------
    estimates : array_like, shape (M, 3)
    truth : array_like, shape (T, 3)

    Returns
    -------
    est_idx, truth_idx : ndarray, shape (min(M, T),), paired indices

    Examples
    --------
    >>> match([[1, 0, 0], [0, 0, 0]], [[0, 0, 0], [1, 0, 0]])
    (array([0, 1]), array([1, 0]))
    """
    e = np.asarray(estimates, dtype=float).reshape(-1, 3)
    t = np.asarray(truth, dtype=float).reshape(-1, 3)
    if len(e) == 0 or len(t) == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    cost = np.linalg.norm(e[:, None, :] - t[None, :, :], axis=-1)
    from scipy.optimize import linear_sum_assignment  # imported on first use: keeps start-up fast

    return linear_sum_assignment(cost)


def paper_errors(estimates: ArrayLike, truth: ArrayLike) -> dict[str, float]:
    """The paper's MAE, MSE, RMSE, MAPE and the mean Euclidean error of paired points.

    Parameters
    ----------
    estimates, truth : array_like, shape (M, 3), already paired row by row

    Examples
    --------
    >>> paper_errors([[1.0, 2.0, 2.0]], [[1.0, 2.0, 4.0]])["mae"]
    0.6666666666666666
    """
    e = np.asarray(estimates, dtype=float).reshape(-1, 3)
    t = np.asarray(truth, dtype=float).reshape(-1, 3)
    if len(e) == 0:
        return {k: math.nan for k in ("euclidean_mean", "euclidean_median", "euclidean_max", "mae", "mse", "rmse", "mape")}
    d = e - t
    dist = np.linalg.norm(d, axis=1)
    nz = np.abs(t) > 1e-12
    mape = float(100 * np.mean(np.abs(d[nz] / t[nz]))) if nz.any() else math.nan
    mse = float(np.mean(d * d))
    return {
        "euclidean_mean": float(dist.mean()),
        "euclidean_median": float(np.median(dist)),
        "euclidean_max": float(dist.max()),
        "mae": float(np.mean(np.abs(d))),
        "mse": mse,
        "rmse": math.sqrt(mse),
        "mape": mape,
    }


def evaluate(
    estimates: ArrayLike,
    truth: ArrayLike,
    *,
    truth_radii: ArrayLike | None = None,
    estimate_radii: ArrayLike | None = None,
    gate: float | None = None,
    truth_semi_axes: ArrayLike | None = None,
    estimate_semi_axes: ArrayLike | None = None,
) -> Metrics:
    """Match estimates to truth and compute all metrics.

    Parameters
    ----------
    estimates : array_like, shape (M, 3), metres
    truth : array_like, shape (T, 3), metres
    truth_radii : array_like, shape (T,), metres, optional
    estimate_radii : array_like, shape (M,), metres, optional (entries may be NaN)
    gate : float, metres, optional; see the module docstring for the default
    truth_semi_axes : array_like, shape (T, 3), metres, optional (rows may be NaN)
    estimate_semi_axes : array_like, shape (M, 3), metres, optional (rows may be NaN);
        with ``truth_semi_axes``, the shape errors of the module docstring are reported

    Returns
    -------
    Metrics
    """
    e = np.asarray(estimates, dtype=float).reshape(-1, 3)
    t = np.asarray(truth, dtype=float).reshape(-1, 3)
    ei, ti = match(e, t)
    dist = np.linalg.norm(e[ei] - t[ti], axis=1) if len(ei) else np.zeros(0)
    tp = int(np.sum(dist <= _gates(ti, truth_radii, gate)))
    errs = paper_errors(e[ei], t[ti])
    radius_error = _radius_error(truth_radii, estimate_radii, ei, ti)
    shape_errors = _shape_errors(truth_semi_axes, estimate_semi_axes, ei, ti)
    return Metrics(
        n_truth=len(t),
        n_estimates=len(e),
        n_matched=len(ei),
        true_positives=tp,
        misses=len(t) - tp,
        false_positives=len(e) - tp,
        recall=tp / len(t) if len(t) else math.nan,
        precision=tp / len(e) if len(e) else math.nan,
        radius_error_mean=radius_error,
        **shape_errors,
        **errs,
    )


def _gates(ti: NDArray[np.intp], truth_radii: ArrayLike | None, gate: float | None) -> NDArray[np.float64]:
    """The distance (metres) within which each matched truth counts as found (see the module docstring).

    Parameters
    ----------
    ti : ndarray, shape (K,), indices of the matched truth
    truth_radii : array_like, shape (T,), metres, or None
    gate : float, metres, or None

    Returns
    -------
    ndarray, shape (K,)
    """
    if gate is not None:
        return np.full(len(ti), float(gate))
    if truth_radii is None:
        return np.full(len(ti), DEFAULT_GATE_M)
    r = np.asarray(truth_radii, dtype=float)[ti]
    # An unknown (NaN) radius gets the unknown-radius gate; np.maximum alone would propagate NaN into a miss.
    return np.where(np.isfinite(r), np.maximum(r, MIN_GATE_M), DEFAULT_GATE_M)


def _radius_error(
    truth_radii: ArrayLike | None, estimate_radii: ArrayLike | None, ei: NDArray[np.intp], ti: NDArray[np.intp]
) -> float | None:
    """Mean absolute radius error (metres) of the matched pairs where both radii are known; None if there are none."""
    if truth_radii is None or estimate_radii is None or not len(ei):
        return None
    er = np.asarray(estimate_radii, dtype=float)[ei]
    tr = np.asarray(truth_radii, dtype=float)[ti]
    ok = np.isfinite(er) & np.isfinite(tr)
    return float(np.mean(np.abs(er[ok] - tr[ok]))) if ok.any() else None


def _shape_errors(
    truth_semi_axes: ArrayLike | None, estimate_semi_axes: ArrayLike | None, ei: NDArray[np.intp], ti: NDArray[np.intp]
) -> dict[str, float | None]:
    """Sorted semi-axis and volume errors of the matched pairs (see the module docstring)."""
    none: dict[str, float | None] = dict.fromkeys(
        ("semi_axis_error_mean", "semi_axis_error_max", "volume_error_mean", "volume_error_pct_mean")
    )
    if truth_semi_axes is None or estimate_semi_axes is None or not len(ei):
        return none
    es = np.sort(np.asarray(estimate_semi_axes, dtype=float).reshape(-1, 3)[ei], axis=1)
    ts = np.sort(np.asarray(truth_semi_axes, dtype=float).reshape(-1, 3)[ti], axis=1)
    ok = np.all(np.isfinite(es), axis=1) & np.all(np.isfinite(ts), axis=1)
    if not ok.any():
        return none
    d = np.abs(es[ok] - ts[ok])
    ev = 4.0 / 3.0 * math.pi * np.prod(es[ok], axis=1)
    tv = 4.0 / 3.0 * math.pi * np.prod(ts[ok], axis=1)
    return {
        "semi_axis_error_mean": float(d.mean()),
        "semi_axis_error_max": float(d.max()),
        "volume_error_mean": float(np.mean(np.abs(ev - tv))),
        "volume_error_pct_mean": float(100 * np.mean(np.abs(ev - tv) / tv)),
    }
