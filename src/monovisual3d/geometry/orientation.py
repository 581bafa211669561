"""Orientations of ellipsoids: the "upright" rotation (third axis along the base frame's vertical) and quaternions.

"Upright" orientation (:func:`rotation_upright`): the third axis along the base frame's vertical ``up``
and a yaw about it, measured from the projection of base x onto the horizontal plane (base y when
``up`` is along x).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError

#: Default vertical of the base frame (z up).
DEFAULT_UP = (0.0, 0.0, 1.0)


def check_up(up: ArrayLike, *, where: str = "up") -> NDArray[np.float64]:
    """Validate a vertical direction and return it as a unit vector, shape (3,).

    Examples
    --------
    >>> check_up([0, 0, 2])
    array([0., 0., 1.])
    """
    try:
        u = np.asarray(up, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected three numbers, got {up!r}") from None
    if u.shape != (3,) or not np.all(np.isfinite(u)):
        raise InputError(f"{where}: expected three finite numbers, got {up!r}")
    n = float(np.linalg.norm(u))
    if not n > 1e-12:
        raise InputError(f"{where}: zero length, expected a direction such as 0,0,1")
    return u / n


def rotation_upright(yaw: ArrayLike = 0.0, up: ArrayLike = DEFAULT_UP) -> NDArray[np.float64]:
    """``R_base_ellipsoid`` of upright ellipsoids: third axis along ``up``, first axis at ``yaw``.

    Parameters
    ----------
    yaw : array_like, shape (...), radians
        Rotation about ``up`` of the first axis, from the horizontal projection of
        base x (of base y when ``up`` is along x), counter-clockwise seen from above.
    up : array_like, shape (3,), base frame, the vertical (any length > 0)

    Returns
    -------
    R_base_ellipsoid : ndarray, shape (..., 3, 3), columns the axes in the base frame

    Examples
    --------
    >>> np.round(rotation_upright(np.pi / 2), 6)[:, 0]  # first axis along base y
    array([0., 1., 0.])
    """
    u = check_up(up)
    ref = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    h0 = ref - (ref @ u) * u
    h0 /= np.linalg.norm(h0)
    h1 = np.cross(u, h0)
    y = np.asarray(yaw, dtype=float)[..., None]
    e1 = np.cos(y) * h0 + np.sin(y) * h1
    e2 = np.cross(u, e1)
    e3 = np.broadcast_to(u, e1.shape)
    return np.stack([e1, e2, e3], axis=-1)


def rotation_from_quaternion_xyzw(quaternion_xyzw: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) from unit quaternions (..., 4) in (x, y, z, w) order (normalised here)."""
    q = np.asarray(quaternion_xyzw, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def quaternion_xyzw_from_rotation(R: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions (..., 4), (x, y, z, w) with w >= 0, of rotation matrices (..., 3, 3)."""
    from scipy.spatial.transform import Rotation  # on first use: scipy.spatial takes 0.2-0.4 s to import

    R = np.asarray(R, dtype=float)
    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat().reshape(R.shape[:-2] + (4,))
    return np.where(q[..., 3:] < 0, -q, q)
