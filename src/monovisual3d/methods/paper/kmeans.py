"""From a posterior grid to object positions: the paper's k-means step."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...checks import is_int
from ...errors import InputError
from ...grid import VoxelGrid
from ...limits import DEFAULT_KEEP_THRESHOLD, MAX_KMEANS_WORK
from ...result import DetectedObject

CENTRES = ("weighted", "geometric")
K_RULES = ("max", "mode", "min", "last")


def _check_kmeans_work(k: int, n_cells: int) -> None:
    """Refuse a k-means beyond :data:`~monovisual3d.limits.MAX_KMEANS_WORK` cluster-cells (one-line error naming --k)."""
    if k * n_cells > MAX_KMEANS_WORK:
        raise InputError(
            f"k: k-means of {k} clusters over {n_cells:,} cells is beyond the {MAX_KMEANS_WORK:.3g} cluster-cells accepted "
            "(monovisual3d.limits.MAX_KMEANS_WORK); give a smaller --k, a coarser --resolution, or use --method bayes"
        )


def choose_k(counts: Sequence[int], rule: str | int = "max") -> int:
    """Number of clusters from the per-view detection counts.

    The paper takes k = the number of objects the detection camera reports;
    it never states what to do when views disagree. ``"max"`` (default) takes
    the largest count (a missed detection lowers a count, it rarely raises
    it); ``"mode"`` the most frequent count (ties: the larger); ``"min"``,
    ``"last"``; or an explicit integer.

    Examples
    --------
    >>> choose_k([3, 2, 3]), choose_k([3, 2, 2], "mode"), choose_k([3, 2, 3], 5)
    (3, 2, 5)
    """
    counts = [int(c) for c in counts if c > 0]
    if is_int(rule):
        if rule < 1:
            raise InputError(f"k: got {rule}, expected a positive number of objects")
        return int(rule)
    if rule not in K_RULES:
        raise InputError(f"k: got {rule!r}, expected a positive integer or one of {list(K_RULES)}")
    if not counts:
        return 0
    if rule == "max":
        return max(counts)
    if rule == "min":
        return min(counts)
    if rule == "last":
        return counts[-1]
    if rule == "mode":
        freq = Counter(counts)
        best = max(freq.values())
        return max(c for c, f in freq.items() if f == best)
    raise InputError(f"k: got {rule!r}, expected a positive integer or one of {list(K_RULES)}")


def kmeans_objects(
    grid: VoxelGrid,
    posterior: NDArray[np.floating],
    k: int,
    *,
    centre: str = "weighted",
    keep_threshold: float = DEFAULT_KEEP_THRESHOLD,
    weighted_kmeans: bool = False,
    seed: int = 0,
) -> list[DetectedObject]:
    """Cluster the surviving cells with k-means and report one object per cluster.

    Parameters
    ----------
    grid : VoxelGrid
    posterior : ndarray, shape grid.shape or (n_cells,), sums to 1
    k : int, number of clusters (capped by the number of surviving cells)
    centre : {"weighted", "geometric"}
        ``weighted``: ``sum(w x) / sum(w)`` over the cluster's cells (the paper's
        Eq. 9 divides by N, a typo); ``geometric``: the k-means centroid.
    keep_threshold : float in (0, 1]; cells with ``p >= keep_threshold * max(p)`` are clustered
    weighted_kmeans : bool, pass the posterior as k-means sample weights (the paper does not)
    seed : int, k-means initialisation seed

    Returns
    -------
    objects : list of DetectedObject, sorted by decreasing score. ``score`` is the
        posterior mass of the cluster; ``covariance`` the weighted covariance of its cells.
    """
    if centre not in CENTRES:
        raise InputError(f"centre: got {centre!r}, expected one of {list(CENTRES)}")
    if not 0.0 < keep_threshold <= 1.0:
        raise InputError(f"keep_threshold: got {keep_threshold}, expected a value in (0, 1]")
    p = np.asarray(posterior, dtype=float).ravel()
    if k <= 0 or not np.any(p > 0):
        return []
    keep = np.flatnonzero(p >= keep_threshold * p.max())
    w = p[keep]
    x = grid.centres_base(keep)
    k = min(k, len(keep))
    _check_kmeans_work(k, len(keep))
    from sklearn.cluster import KMeans
    from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

    km = KMeans(n_clusters=k, n_init=4, random_state=seed)
    # one thread: these clusterings are small, and BLAS/OpenMP thread pools on a busy
    # 2-core machine made k-means 5-30x slower
    with threadpool_limits(limits=1):
        labels = km.fit_predict(x, sample_weight=w if weighted_kmeans else None)
    objects = []
    for j in range(k):
        sel = labels == j
        wj, xj = w[sel], x[sel]
        mean_w = (wj[:, None] * xj).sum(0) / wj.sum()
        d = xj - mean_w
        cov = (wj[:, None, None] * (d[:, :, None] * d[:, None, :])).sum(0) / wj.sum()
        position = mean_w if centre == "weighted" else km.cluster_centers_[j]
        objects.append(DetectedObject(position=position, score=float(wj.sum()), covariance=cov, n_cells=int(sel.sum())))
    objects.sort(key=lambda o: -o.score)
    return objects
