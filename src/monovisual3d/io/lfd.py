"""The LfD data layout (Rubino, Crocco, Del Bue, TPAMI 2017) -> a session and a truth file.

A folder of numpy ``.npy`` arrays, for ``n`` views and ``m`` objects (float64 unless said):

- ``intrinsics.npy`` (3, 3): the camera matrix ``K`` (OpenCV pixels: pixel centres at integers);
- ``camera_poses.npy`` (4 n, 3): rows ``4f .. 4f+3`` are the transpose of view f's 3 x 4 world-to-camera
  matrix ``[R | t]`` (OpenCV camera axes, i.e. our optical frame; metres), so ``T_optical_base = [R | t]``;
- ``bounding_boxes.npy`` (n, 4 m): columns ``4j .. 4j+3`` are object j's box ``x_min, y_min, x_max, y_max``;
- ``visibility.npy`` (n, m), bool: whether object j has a box in view f;
- ``gt.npy`` (m, 4, 4), optional: each object's ground-truth ellipsoid as a dual quadric ``Q*``
  (centre ``Q*[:3, 3] / Q*[3, 3]``).

The base frame is the files' world frame. The principal point and every box move by half a pixel to our
convention (pixel centres at integer + 0.5); this shifts the image coordinates only, not the geometry.
The image size is not in the files: it is given, or taken as the common sensor size nearest twice the principal
point (``2 (c + 0.5)``; a calibrated principal point lies a few pixels off the image centre) that holds the boxes, else
twice the principal point, with a warning unless twice the principal point is itself a common size.

Boxes are pooled per view and sorted by ``x_min`` (then ``y_min``), so their order says nothing about
which object they belong to; ``keep_association`` writes each box's column ``j`` as its ``track`` id.
Every problem is one line naming the file, the entry and what was expected (``InputError``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, InputWarning, one_line
from ..geometry.ellipsoid import Ellipsoid
from ..geometry.quadric import ellipsoid_from_dual_quadric
from ..session import Session
from ..session.load import session_from_dict
from .image_size import image_size_from_principal_point, size_pair

#: Largest deviation of ``R R^T`` from the identity accepted in a pose (files store rotations to ~7 digits).
ROTATION_TOL = 1e-3
#: Shift from OpenCV pixel coordinates (centres at integers) to ours (centres at integer + 0.5), pixels.
PIXEL_SHIFT = 0.5


@dataclass(frozen=True)
class LfdArrays:
    """The validated arrays of an LfD folder.

    Attributes
    ----------
    K : ndarray, shape (3, 3), pixels, OpenCV convention (as in the file)
    T_optical_base : ndarray, shape (n, 4, 4), world (base) to camera, metres
    boxes_xyxy : ndarray, shape (n, m, 4), pixels, OpenCV convention; NaN where not visible
    visibility : ndarray, shape (n, m), bool
    gt : tuple of Ellipsoid or None, the truth in the base frame (``gt.npy``)
    source : str, the folder
    """

    K: NDArray[np.float64]
    T_optical_base: NDArray[np.float64]
    boxes_xyxy: NDArray[np.float64]
    visibility: NDArray[np.bool_]
    gt: tuple[Ellipsoid, ...] | None
    source: str


def _load(folder: Path, name: str, what: str, required: bool = True) -> NDArray[Any] | None:
    path = folder / name
    where = one_line(str(path))
    if not path.is_file():
        if required:
            raise InputError(f"{where}: missing, expected {what}")
        return None
    try:
        arr = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise InputError(f"{where}: not a numpy .npy array ({one_line(str(exc), 80)}), expected {what}") from None
    if not isinstance(arr, np.ndarray) or arr.dtype.kind not in "biuf":
        raise InputError(f"{where}: dtype {getattr(arr, 'dtype', type(arr).__name__)}, expected numbers ({what})")
    return arr


def _shape(arr: NDArray[Any], shape: tuple[int, ...], where: str, what: str) -> None:
    if arr.shape != shape:
        raise InputError(f"{where}: shape {arr.shape}, expected {shape} ({what})")


def _finite(arr: NDArray[Any], where: str) -> None:
    bad = np.argwhere(~np.isfinite(arr))
    if len(bad):
        raise InputError(f"{where}: entry {tuple(int(i) for i in bad[0])} is {arr[tuple(bad[0])]}, expected finite numbers")


def _poses(raw: NDArray[Any], n: int, where: str) -> NDArray[np.float64]:
    """``T_optical_base`` (n, 4, 4) from the stacked transposed ``[R | t]``, rotations re-orthonormalised."""
    _shape(raw, (4 * n, 3), where, f"4 rows per view for the {n} views of bounding_boxes.npy")
    _finite(raw, where)
    out = np.tile(np.eye(4), (n, 1, 1))
    for f in range(n):
        Rt = raw[4 * f : 4 * f + 4].T.astype(float)
        R = Rt[:, :3]
        det = float(np.linalg.det(R))
        err = float(np.max(np.abs(R @ R.T - np.eye(3))))
        if not (det > 0 and err <= ROTATION_TOL):
            raise InputError(
                f"{where}: view {f} (rows {4 * f}-{4 * f + 3}): R has det {det:.3g} and |R R^T - I| up to {err:.2g}, "
                "expected a rotation (the pose must be invertible)"
            )
        U, _, Vt = np.linalg.svd(R)
        out[f, :3, :3] = U @ Vt
        out[f, :3, 3] = Rt[:, 3]
    return out


def _boxes(raw: NDArray[Any], vis: NDArray[Any], folder: Path) -> NDArray[np.float64]:
    """Boxes (n, m, 4); every visible object must have a finite box with x_min < x_max and y_min < y_max."""
    where = one_line(str(folder / "bounding_boxes.npy"))
    n, m = vis.shape
    _shape(raw, (n, 4 * m), where, f"4 columns per object for the {m} objects of visibility.npy")
    boxes = raw.astype(float).reshape(n, m, 4)
    for f, j in np.argwhere(vis):
        b = boxes[f, j]
        cols = f"view {f}, object {j} (columns {4 * j}-{4 * j + 3})"
        if not np.all(np.isfinite(b)):
            raise InputError(f"{where}: {cols}: {b.tolist()} is not finite, but visibility.npy says the object is visible")
        if not (b[0] < b[2] and b[1] < b[3]):
            raise InputError(f"{where}: {cols}: {b.tolist()}, expected x_min < x_max and y_min < y_max for a visible object")
    return np.where(vis[..., None], boxes, np.nan)


def _truth(raw: NDArray[Any], m: int, folder: Path) -> tuple[Ellipsoid, ...]:
    where = one_line(str(folder / "gt.npy"))
    _shape(raw, (m, 4, 4), where, f"one 4 x 4 dual quadric per object of visibility.npy ({m})")
    _finite(raw, where)
    out = []
    for j, Q in enumerate(raw.astype(float)):
        try:
            centre, semi_axes, R = ellipsoid_from_dual_quadric(Q)
        except InputError as exc:
            raise InputError(f"{where}: object {j}: {str(exc).removeprefix('dual quadric: ')}") from None
        out.append(Ellipsoid.from_rotation(centre, semi_axes, R))
    return tuple(out)


def read_lfd_arrays(folder: str | Path, *, truth: bool = True) -> LfdArrays:
    """Read and check the arrays of an LfD folder (see the module docstring).

    Parameters
    ----------
    folder : path of the folder
    truth : bool, also read ``gt.npy`` (an error when it is missing)

    Raises
    ------
    InputError
        One line ``FILE: entry: problem`` for a missing file, a wrong shape, a NaN, a pose that is not a
        rotation, or a visible object without a box.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(
            f"{one_line(str(folder))}: not a folder, expected the LfD arrays (intrinsics.npy, camera_poses.npy, ...)"
        )
    vis_raw = _load(folder, "visibility.npy", "an n x m array of booleans (view, object)")
    assert vis_raw is not None
    if vis_raw.ndim != 2 or vis_raw.shape[0] < 1 or vis_raw.shape[1] < 1:
        raise InputError(f"{one_line(str(folder / 'visibility.npy'))}: shape {vis_raw.shape}, expected (views, objects)")
    if not np.all((vis_raw == 0) | (vis_raw == 1)):
        raise InputError(f"{one_line(str(folder / 'visibility.npy'))}: values other than 0/1, expected booleans")
    vis = vis_raw.astype(bool)
    n, m = vis.shape
    K = _load(folder, "intrinsics.npy", "the 3 x 3 camera matrix")
    assert K is not None
    kw = one_line(str(folder / "intrinsics.npy"))
    _shape(K, (3, 3), kw, "the camera matrix")
    _finite(K, kw)
    if not (K[0, 0] > 0 and K[1, 1] > 0 and np.allclose(K[2], [0, 0, 1]) and K[1, 0] == 0):
        raise InputError(f"{kw}: {np.round(K, 6).tolist()}, expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0")
    poses = _load(folder, "camera_poses.npy", "4 n x 3: per view the transpose of [R | t]")
    boxes = _load(folder, "bounding_boxes.npy", "n x 4 m: per view and object x_min, y_min, x_max, y_max")
    assert poses is not None and boxes is not None
    T = _poses(poses, n, one_line(str(folder / "camera_poses.npy")))
    gt = None
    if truth:
        raw = _load(folder, "gt.npy", "m x 4 x 4: one dual quadric per object")
        assert raw is not None
        gt = _truth(raw, m, folder)
    return LfdArrays(K.astype(float), T, _boxes(boxes, vis, folder), vis, gt, one_line(str(folder)))


def _image_size(arrays: LfdArrays, cx: float, cy: float) -> tuple[int, int]:
    """The images' size when not given (:func:`~monovisual3d.io.image_size.image_size_from_principal_point`), with a
    warning unless twice the principal point is a standard size."""
    seen = arrays.boxes_xyxy[arrays.visibility] + PIXEL_SHIFT
    extent = (float(seen[:, 2].max()), float(seen[:, 3].max())) if len(seen) else (0.0, 0.0)
    size, how = image_size_from_principal_point(cx, cy, extent)
    if min(size) < 1:
        raise InputError(f"{arrays.source}: principal point ({cx:g}, {cy:g}) gives no image size; give the image size")
    if how != "exact":
        taken = "the common sensor size nearest" if how == "standard" else "no common sensor size is near"
        warnings.warn(
            InputWarning(
                f"{arrays.source}: no image size given; taking {size[0]}x{size[1]} ({taken} twice the principal point, "
                f"{2 * cx:.0f}x{2 * cy:.0f}); give the image size (image_size, --image-size) if the images differ"
            ),
            stacklevel=3,
        )
    return size


def session_from_lfd(arrays: LfdArrays, *, keep_association: bool = False, image_size: tuple[int, int] | None = None) -> Session:
    """The session of LfD arrays: boxes pooled per view and sorted by ``x_min`` (``track`` = column with ``keep_association``).

    Parameters
    ----------
    arrays : LfdArrays
    keep_association : bool, write each box's object index as its ``track`` id
    image_size : (width, height) in pixels, or None: the common sensor size nearest twice the principal point
        (``2 (cx + 0.5)``, ``2 (cy + 0.5)``) that holds the boxes, else twice the principal point
        (:func:`~monovisual3d.io.image_size.image_size_from_principal_point`), with a warning unless twice the
        principal point is itself a common size
    """
    K = arrays.K
    fx, fy, cx, cy = float(K[0, 0]), float(K[1, 1]), float(K[0, 2]) + PIXEL_SHIFT, float(K[1, 2]) + PIXEL_SHIFT
    if image_size is None:
        image_size = _image_size(arrays, cx, cy)
    else:
        image_size = size_pair(image_size, "image_size (--image-size)")
    views = []
    for f in range(len(arrays.visibility)):
        T_base_optical = np.linalg.inv(arrays.T_optical_base[f])
        dets = []
        for j in np.flatnonzero(arrays.visibility[f]):
            det: dict[str, Any] = {"bbox_xyxy": (arrays.boxes_xyxy[f, j] + PIXEL_SHIFT).tolist()}
            if keep_association:
                det["track"] = int(j)
            dets.append(det)
        dets.sort(key=lambda d: (d["bbox_xyxy"][0], d["bbox_xyxy"][1]))
        views.append({"pose": {"matrix": T_base_optical.tolist()}, "detections": dets})
    data = {
        "camera": {"width": int(image_size[0]), "height": int(image_size[1]), "fx": fx, "fy": fy, "cx": cx, "cy": cy},
        "views": views,
    }
    return session_from_dict(data, arrays.source)


def truth_from_lfd(arrays: LfdArrays) -> dict[str, Any]:
    """The truth file of LfD arrays: ``{"objects": [...]}`` with each object's centre, semi-axes and orientation."""
    if arrays.gt is None:
        raise InputError(f"{arrays.source}: gt.npy was not read, expected the ground-truth dual quadrics")
    return {"objects": [{**e.to_dict(), "label": f"object {j}"} for j, e in enumerate(arrays.gt)]}


def read_lfd(
    folder: str | Path, *, keep_association: bool = False, truth: bool = True, image_size: tuple[int, int] | None = None
) -> tuple[Session, dict[str, Any] | None]:
    """The session and (with ``truth``) the truth of an LfD folder; see :func:`session_from_lfd`.

    Examples
    --------
    >>> session, truth = read_lfd("../shared/data/aldoma")  # doctest: +SKIP
    >>> len(session.views), len(truth["objects"])  # doctest: +SKIP
    (8, 6)
    """
    arrays = read_lfd_arrays(folder, truth=truth)
    session = session_from_lfd(arrays, keep_association=keep_association, image_size=image_size)
    return session, (truth_from_lfd(arrays) if truth else None)
