"""The box of a smooth curve in the image from a few samples: each extreme sample refined by a parabola.

Under lens distortion a solid's box has no closed form: its outline (an ellipsoid's rim, a cylinder's rim circles, a
cuboid's edges) is sampled and projected, and the box is that of the samples. Dense sampling (hundreds of points per
outline) makes the shape fits slow, for they predict every box of every view at every step of a least-squares fit
and of its Jacobian. A smooth curve's extreme coordinate is found as well from a few dozen samples: the parabola
through the extreme sample and its two neighbours peaks within a small fraction of a pixel of the true extreme (the
error falls as the fourth power of the sample spacing), closer than hundreds of samples without it.

:func:`sampled_curve_box` is the fast box; the dense box (:func:`dense_curve_box`, the samples' own min and max) is
its readable reference, and the tests compare them on densely sampled outlines.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def dense_curve_box(uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """The box of the samples themselves (the reference).

    Parameters
    ----------
    uv : ndarray, shape (..., n, 2), pixels, samples along a curve (NaN where a point is behind the camera)

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels; NaN where a sample is NaN
    """
    return np.concatenate([uv.min(axis=-2), uv.max(axis=-2)], axis=-1)


def sampled_curve_box(uv: NDArray[np.float64], *, closed: bool) -> NDArray[np.float64]:
    """The box of a smooth curve from samples: each coordinate's extreme sample refined by the parabola through it
    and its neighbours.

    Parameters
    ----------
    uv : ndarray, shape (..., n, 2), pixels, samples at equal steps of the curve's parameter (n >= 3); NaN where a
        point is behind the camera
    closed : bool, the curve is closed (sample n-1 neighbours sample 0), else an open arc whose ends are kept as
        sampled (an extreme at an end is the end itself)

    Returns
    -------
    bbox_xyxy : ndarray, shape (..., 4), pixels; NaN where a sample is NaN

    Examples
    --------
    >>> t = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    >>> uv = np.stack([100 + 50 * np.cos(t + 0.1), 80 + 30 * np.sin(t + 0.1)], axis=-1)
    >>> sampled_curve_box(uv, closed=True).round(2)  # the ellipse's box, 50 x 30 about (100, 80); 0.25 px off unrefined
    array([ 50.,  50., 150., 110.])
    """
    uv = np.asarray(uv, dtype=float)
    n = uv.shape[-2]
    if n < 3:
        return dense_curve_box(uv)
    base = dense_curve_box(uv)
    coords = np.moveaxis(uv, -1, -2)  # (..., 2, n): u, v
    signs = np.array([-1.0, -1.0, 1.0, 1.0])[:, None]  # the minimum as the maximum of -x
    out = signs[:, 0] * _parabola_peak(signs * np.concatenate([coords, coords], axis=-2), closed)  # all four at once
    return np.where(np.isfinite(base), out, base)


def _parabola_peak(x: NDArray[np.float64], closed: bool) -> NDArray[np.float64]:
    """The maximum (...) over the last axis (n samples) of ``x``, refined by the parabola through the largest sample
    and its neighbours (never below that sample)."""
    n = x.shape[-1]
    i = np.nanargmax(np.where(np.isfinite(x), x, -np.inf), axis=-1)[..., None]
    y1 = np.take_along_axis(x, i, axis=-1)[..., 0]
    if closed:
        y0 = np.take_along_axis(x, (i - 1) % n, axis=-1)[..., 0]
        y2 = np.take_along_axis(x, (i + 1) % n, axis=-1)[..., 0]
        interior = np.ones(y1.shape, dtype=bool)
    else:
        y0 = np.take_along_axis(x, np.maximum(i - 1, 0), axis=-1)[..., 0]
        y2 = np.take_along_axis(x, np.minimum(i + 1, n - 1), axis=-1)[..., 0]
        interior = (i[..., 0] > 0) & (i[..., 0] < n - 1)
    curvature = y0 - 2.0 * y1 + y2  # < 0 at a proper interior maximum
    ok = interior & (curvature < 0)
    c = np.where(ok, curvature, -1.0)
    step = np.clip(0.5 * (y0 - y2) / c, -0.5, 0.5)  # the vertex, in samples from the largest one
    return np.where(ok, y1 - 0.25 * (y0 - y2) * step, y1)
