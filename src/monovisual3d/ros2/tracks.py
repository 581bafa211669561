"""Track ids that stay with a fruit from one estimate to the next.

Every estimate is made afresh from all views, so its objects come in no particular order. Each new
estimate is matched to the previous one by minimum total distance (Hungarian); a pair closer than the gate
keeps its id, every other object gets a new one. Ids are never reused within a session.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

#: Largest move, metres, of a fruit's estimate between two estimates that keeps its id: under half the distance
#: between the centres of two touching 8 cm fruit, far above the few millimetres a new view moves an estimate.
TRACK_GATE_M = 0.03


def match_tracks(
    previous_ids: ArrayLike, previous_p_base: ArrayLike, p_base: ArrayLike, gate_m: float = TRACK_GATE_M
) -> NDArray[np.int64]:
    """For each new position, the id of the previous position it continues, or -1 (a new fruit).

    Parameters
    ----------
    previous_ids : array_like, shape (M,), int
    previous_p_base : array_like, shape (M, 3), metres, base frame
    p_base : array_like, shape (N, 3), metres, base frame
    gate_m : float, metres: pairs farther apart are not matched

    Returns
    -------
    ids : ndarray, shape (N,), int64, previous ids or -1

    Examples
    --------
    >>> match_tracks([7, 8], [[0, 0, 0], [1, 0, 0]], [[1.01, 0, 0], [2, 0, 0]]).tolist()
    [8, -1]
    """
    prev_ids = np.asarray(previous_ids, dtype=np.int64).reshape(-1)
    prev = np.asarray(previous_p_base, dtype=float).reshape(-1, 3)
    new = np.asarray(p_base, dtype=float).reshape(-1, 3)
    if prev.shape[0] != prev_ids.size:
        raise ValueError(f"previous_ids: {prev_ids.size} ids for {prev.shape[0]} positions")
    out = np.full(new.shape[0], -1, dtype=np.int64)
    if prev.shape[0] == 0 or new.shape[0] == 0:
        return out
    d = np.linalg.norm(new[:, None, :] - prev[None, :, :], axis=2)
    rows, cols = linear_sum_assignment(np.where(d <= gate_m, d, gate_m * 1e3))  # out-of-gate pairs only as a last resort
    keep = d[rows, cols] <= gate_m
    out[rows[keep]] = prev_ids[cols[keep]]
    return out


@dataclass
class TrackTable:
    """The ids of the last estimate; :meth:`update` gives the next estimate's ids.

    Attributes
    ----------
    gate_m : float, metres, see :func:`match_tracks`
    ids : ndarray, shape (M,), int64, the ids of the last estimate
    p_base : ndarray, shape (M, 3), metres, its positions
    next_id : int, the next new id
    """

    gate_m: float = TRACK_GATE_M
    ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    p_base: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    next_id: int = 0

    def update(self, p_base: ArrayLike) -> NDArray[np.int64]:
        """Ids of the new positions (shape (N, 3), metres): previous ids where matched, new ones elsewhere."""
        p = np.asarray(p_base, dtype=float).reshape(-1, 3)
        ids = match_tracks(self.ids, self.p_base, p, self.gate_m)
        for i in np.flatnonzero(ids < 0):
            ids[i] = self.next_id
            self.next_id += 1
        self.ids, self.p_base = ids.copy(), p.copy()
        return ids


__all__ = ["TRACK_GATE_M", "TrackTable", "match_tracks"]
