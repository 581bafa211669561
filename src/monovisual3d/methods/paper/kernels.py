"""The paper's per-box kernels and the per-view mixture likelihood (numpy reference).

All functions take projected cell centres ``uv`` of shape (N, 2) in pixels,
with NaN for cells behind the camera, and boxes ``bbox_xyxy`` of shape (4,)
or (M, 4). Cells behind the camera score zero, as in the paper.

The kernel names and ids (:data:`monovisual3d.methods.paper.engine.params.KERNELS`) live in the engine,
which compiles the fast twins of these functions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...errors import InputError
from .engine.params import check_kernel


def square_kernel(uv: NDArray[np.floating], bbox_xyxy: NDArray[np.floating]) -> NDArray[np.float64]:
    """1 where ``uv`` lies inside the box (edges included), else 0 (paper Eq. 3).

    Parameters
    ----------
    uv : ndarray, shape (N, 2), pixels
    bbox_xyxy : ndarray, shape (4,), pixels

    Returns
    -------
    k : ndarray, shape (N,), float64

    Examples
    --------
    >>> square_kernel(np.array([[5.0, 5.0], [20.0, 5.0]]), np.array([0, 0, 10, 10]))
    array([1., 0.])
    """
    x1, y1, x2, y2 = bbox_xyxy
    u, v = uv[:, 0], uv[:, 1]
    return ((u >= x1) & (u <= x2) & (v >= y1) & (v <= y2)).astype(np.float64)


def gaussian_kernel(
    uv: NDArray[np.floating], bbox_xyxy: NDArray[np.floating], sigma_fraction: float = 0.5
) -> NDArray[np.float64]:
    """Unnormalised 2D Gaussian centred on the box (paper Eq. 4).

    ``exp(-(du^2 / 2 sx^2 + dv^2 / 2 sy^2))`` with ``sx = sigma_fraction * width``
    and ``sy = sigma_fraction * height`` (the paper used 1/2, and 1/3 with noise).

    Examples
    --------
    >>> gaussian_kernel(np.array([[5.0, 5.0]]), np.array([0, 0, 10, 10]))
    array([1.])
    """
    x1, y1, x2, y2 = bbox_xyxy
    sx = sigma_fraction * (x2 - x1)
    sy = sigma_fraction * (y2 - y1)
    du = uv[:, 0] - 0.5 * (x1 + x2)
    dv = uv[:, 1] - 0.5 * (y1 + y2)
    out = np.exp(-(du * du / (2 * sx * sx) + dv * dv / (2 * sy * sy)))
    return np.nan_to_num(out, nan=0.0)


def paper_view_likelihood(
    uv: NDArray[np.floating],
    boxes_xyxy: NDArray[np.floating],
    kernel: str = "gaussian",
    sigma_fraction: float = 0.5,
) -> NDArray[np.float64]:
    """The paper's per-view likelihood: the mean of the kernel over the N boxes (Eq. 1).

    Not normalised by its maximum; the filter does that over the whole grid (Eq. 5).

    Parameters
    ----------
    uv : ndarray, shape (C, 2), pixels (NaN behind the camera)
    boxes_xyxy : ndarray, shape (N, 4), N >= 1
    kernel : {"square", "gaussian"}
    sigma_fraction : float, Gaussian sigma as a fraction of the box size

    Returns
    -------
    likelihood : ndarray, shape (C,), float64
    """
    check_kernel(kernel)
    boxes = np.asarray(boxes_xyxy, dtype=float).reshape(-1, 4)
    if len(boxes) == 0:
        raise InputError("paper_view_likelihood: a view needs at least one box")
    out = np.zeros(len(uv))
    for box in boxes:
        out += square_kernel(uv, box) if kernel == "square" else gaussian_kernel(uv, box, sigma_fraction)
    return out / len(boxes)


def paper_view_likelihood_slow(
    uv: NDArray[np.floating], boxes_xyxy: NDArray[np.floating], kernel: str, sigma_fraction: float = 0.5
) -> NDArray[np.float64]:
    """Per-cell Python loop of the paper's Algorithm 1 (test reference only; slow)."""
    import math

    out = np.zeros(len(uv))
    for i in range(len(uv)):
        u, v = float(uv[i, 0]), float(uv[i, 1])
        if math.isfinite(u) and math.isfinite(v):
            out[i] = paper_cell_likelihood(u, v, boxes_xyxy, kernel, sigma_fraction)
    return out


def paper_cell_likelihood(
    u: float, v: float, boxes_xyxy: NDArray[np.floating] | list[tuple[float, ...]], kernel: str, sigma_fraction: float
) -> float:
    """The paper's mixture (Eq. 1) for one projected cell ``(u, v)``, box by box in plain Python (Algorithm 1's inner loop)."""
    import math

    acc = 0.0
    for x1, y1, x2, y2 in boxes_xyxy:
        if kernel == "square":
            acc += 1.0 if (x1 <= u <= x2 and y1 <= v <= y2) else 0.0
        else:
            sx, sy = sigma_fraction * (x2 - x1), sigma_fraction * (y2 - y1)
            du, dv = u - 0.5 * (x1 + x2), v - 0.5 * (y1 + y2)
            acc += math.exp(-(du * du / (2 * sx * sx) + dv * dv / (2 * sy * sy)))
    return acc / len(boxes_xyxy)
