"""Rigid transforms and the frame conventions of the project.

Naming rule: ``T_a_b`` maps points from frame ``b`` into frame ``a``
(``p_a = T_a_b @ p_b``), so ``T_a_c = T_a_b @ T_b_c``.

Frames:

- ``base``: the robot base frame.
- ``optical``: the camera's optical frame (z forward, x right, y down).
- ``camera_link``: the ROS-style camera body frame (x forward, y left, z up).
- ``grid``: the voxel grid's own axes.

Quaternions are always in ``(x, y, z, w)`` order (``quaternion_xyzw``), as in
ROS and :class:`scipy.spatial.transform.Rotation`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .checks import finite_array
from .errors import InputError

#: Rotation of the optical frame expressed in the ROS camera_link frame, as
#: given in the paper: quaternion (x, y, z, w) = (-0.5, 0.5, -0.5, 0.5).
QUATERNION_XYZW_CAMERALINK_OPTICAL = np.array([-0.5, 0.5, -0.5, 0.5])

#: Default tolerance on ``max |R^T R - I|`` and ``|det R - 1|`` for rotations.
ROTATION_TOL = 1e-4


def check_transform(T: ArrayLike, *, where: str = "matrix", tol: float = ROTATION_TOL) -> NDArray[np.float64]:
    """Validate a 4x4 rigid homogeneous transform.

    Parameters
    ----------
    T : array_like, shape (4, 4)
        Homogeneous transform, row-major.
    where : str
        Name used in the error message.
    tol : float
        Accepted deviation from orthonormality of the rotation block.

    Returns
    -------
    T : ndarray, shape (4, 4), float64

    Examples
    --------
    >>> check_transform(np.eye(4)).shape
    (4, 4)
    """
    arr = finite_array(T, (4, 4), where)
    R = arr[:3, :3]
    with np.errstate(over="ignore", invalid="ignore"):  # huge entries give inf/NaN, rejected below (not > tol: NaN too)
        err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not err <= tol:
        raise InputError(f"{where}: rotation block is not orthonormal (max |R^T R - I| = {err:.3g}, expected < {tol:g})")
    det = float(np.linalg.det(R))
    if det < 0:
        raise InputError(f"{where}: rotation block has determinant {det:.3g}, expected +1 (a reflection, not a rotation)")
    if not np.allclose(arr[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise InputError(f"{where}: last row is {arr[3].tolist()}, expected [0, 0, 0, 1]")
    return arr


def transform_from_position_quaternion(position: ArrayLike, quaternion_xyzw: ArrayLike) -> NDArray[np.float64]:
    """Build ``T_a_b`` from the position of b's origin in a and b's orientation in a.

    Parameters
    ----------
    position : array_like, shape (3,), metres
    quaternion_xyzw : array_like, shape (4,), unit quaternion (x, y, z, w)

    Returns
    -------
    T : ndarray, shape (4, 4), float64

    Examples
    --------
    >>> transform_from_position_quaternion([1, 2, 3], [0, 0, 0, 1])[:3, 3]
    array([1., 2., 3.])
    """
    T = np.eye(4)
    T[:3, :3] = rotation_from_quaternion(quaternion_xyzw)
    T[:3, 3] = np.asarray(position, dtype=float)
    return T


def rotation_from_quaternion(quaternion_xyzw: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix of a quaternion, normalised first (as :meth:`scipy.spatial.transform.Rotation.from_quat`).

    Plain numpy, so that reading a session does not import ``scipy.spatial`` (0.2-0.4 s, issue 56); equal to
    scipy's to rounding (tested).

    Parameters
    ----------
    quaternion_xyzw : array_like, shape (4,), (x, y, z, w), not zero

    Returns
    -------
    R : ndarray, shape (3, 3), float64

    Examples
    --------
    >>> rotation_from_quaternion([0, 0, 0, 2])
    array([[1., 0., 0.],
           [0., 1., 0.],
           [0., 0., 1.]])
    """
    q = np.asarray(quaternion_xyzw, dtype=float)
    x, y, z, w = (q / np.linalg.norm(q)).tolist()
    xx, yy, zz, ww = x * x, y * y, z * z, w * w
    xy, xz, xw, yz, yw, zw = x * y, x * z, x * w, y * z, y * w, z * w
    return np.array(
        [
            [xx - yy - zz + ww, 2 * (xy - zw), 2 * (xz + yw)],
            [2 * (xy + zw), -xx + yy - zz + ww, 2 * (yz - xw)],
            [2 * (xz - yw), 2 * (yz + xw), -xx - yy + zz + ww],
        ]
    )


def quaternion_from_rotation(R: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion ``(x, y, z, w)`` of a rotation matrix, as :meth:`scipy.spatial.transform.Rotation.from_matrix`
    (Markley's method: the largest of the four candidate components first; either sign).

    Parameters
    ----------
    R : array_like, shape (3, 3), a rotation

    Returns
    -------
    quaternion_xyzw : ndarray, shape (4,), float64, unit norm

    Examples
    --------
    >>> quaternion_from_rotation(np.eye(3))
    array([0., 0., 0., 1.])
    """
    R = np.asarray(R, dtype=float)
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    choice = int(np.argmax([R[0, 0], R[1, 1], R[2, 2], trace]))
    q = np.empty(4)
    if choice == 3:
        q[0], q[1], q[2], q[3] = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1], 1 + trace
    else:
        i = choice
        j, k = (i + 1) % 3, (i + 2) % 3
        q[i] = 1 - trace + 2 * R[i, i]
        q[j] = R[j, i] + R[i, j]
        q[k] = R[k, i] + R[i, k]
        q[3] = R[k, j] - R[j, k]
    return q / np.linalg.norm(q)


def position_quaternion_from_transform(T: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Split ``T`` into position (3,) and quaternion_xyzw (4,) with w >= 0."""
    T = np.asarray(T, dtype=float)
    q = quaternion_from_rotation(T[:3, :3])
    if q[3] < 0:
        q = -q
    return T[:3, 3].copy(), q


def invert_transform(T: ArrayLike) -> NDArray[np.float64]:
    """Inverse of a rigid transform: ``T_b_a`` from ``T_a_b``.

    Examples
    --------
    >>> T = transform_from_position_quaternion([1, 0, 0], [0, 0, 0, 1])
    >>> invert_transform(T)[:3, 3]
    array([-1., -0., -0.])
    """
    T = np.asarray(T, dtype=float)
    out = np.eye(4)
    R = T[:3, :3]
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ T[:3, 3]
    return out


def transform_points(T_a_b: ArrayLike, p_b: ArrayLike) -> NDArray[np.float64]:
    """Apply ``T_a_b`` to points.

    Parameters
    ----------
    T_a_b : array_like, shape (4, 4)
    p_b : array_like, shape (..., 3), points in frame b

    Returns
    -------
    p_a : ndarray, shape (..., 3), points in frame a
    """
    T = np.asarray(T_a_b, dtype=float)
    p = np.asarray(p_b, dtype=float)
    return p @ T[:3, :3].T + T[:3, 3]


def T_cameralink_optical() -> NDArray[np.float64]:
    """``T_cameralink_optical``: the fixed rotation from the optical frame to the ROS camera_link frame."""
    return transform_from_position_quaternion(np.zeros(3), QUATERNION_XYZW_CAMERALINK_OPTICAL)


def T_base_optical_from_T_base_cameralink(T_base_cameralink: ArrayLike) -> NDArray[np.float64]:
    """Convert a camera_link pose (x forward, y left, z up) to an optical pose (z forward, x right, y down)."""
    return np.asarray(T_base_cameralink, dtype=float) @ T_cameralink_optical()


def look_at(position: ArrayLike, target: ArrayLike, up: ArrayLike = (0.0, 0.0, 1.0)) -> NDArray[np.float64]:
    """``T_base_optical`` of a camera at ``position`` whose optical axis points at ``target``.

    The image's "up" (-y optical) is aligned as well as possible with ``up``
    (base frame).

    Parameters
    ----------
    position, target : array_like, shape (3,), metres, base frame
    up : array_like, shape (3,), base frame

    Returns
    -------
    T_base_optical : ndarray, shape (4, 4)

    Examples
    --------
    >>> T = look_at([0, 0, 0], [1, 0, 0])
    >>> np.round(T[:3, 2], 6)  # optical z points along base x
    array([1., 0., 0.])
    """
    position = np.asarray(position, dtype=float)
    z = np.asarray(target, dtype=float) - position
    nz = np.linalg.norm(z)
    if nz == 0:
        raise InputError("look_at: position and target coincide")
    z = z / nz
    up = np.asarray(up, dtype=float)
    x = np.cross(z, up)  # right = forward x up  (with y down)
    if np.linalg.norm(x) < 1e-9:
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, position
    return T
