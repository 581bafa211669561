"""The bounding-box camera: exact ray casting of a :class:`~monovisual3d.sim.scene.Scene`.

One ray per pixel centre ``(u + 0.5, v + 0.5)`` (see :mod:`monovisual3d.camera`
for the pixel convention) is intersected with every fruit (sphere or ellipsoid), leaf
(rectangle) and stem (finite cylinder with end caps); the nearest hit wins. The
result is a label image (fruit index, :data:`BACKGROUND` or :data:`OCCLUDER`)
and, per fruit, the box of its VISIBLE pixels, which is what the Gazebo
bounding-box camera of the paper reports:

- occluded parts are not in the box, a fully hidden fruit has no box (NaN row);
- a fruit cut by the image border gets the clipped box;
- boxes use the edge convention: ``x1`` = smallest visible column,
  ``x2`` = largest visible column + 1 (likewise rows), so a single visible pixel
  ``(i, j)`` gives the box ``(i, j, i + 1, j + 1)``.

With ``supersample = s`` each pixel is sampled by ``s x s`` sub-pixel rays (at
``(i + 0.5) / s``), the label image is ``s`` times larger and the box edges are
multiples of ``1 / s`` px: sub-pixel accuracy for the price of ``s**2`` rays.

Everything is computed in the optical frame (camera centre at the origin);
:func:`label_image_reference` is the readable per-ray reference the vectorised
kernel is tested against.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import is_int
from ..errors import InputError
from ..frames import check_transform, invert_transform, transform_points
from .scene import EllipsoidFruit, Leaf, Scene, Stem

#: Label of pixels that see nothing.
BACKGROUND = -1
#: Label of pixels that see a leaf or a stem.
OCCLUDER = -2
#: Side of the square image tiles, in (sub-)pixels, that are intersected at a time. Each tile is
#: only tested against the objects whose bounding spheres meet the tile's cone of rays.
TILE = 64
#: Images with at most this many rays keep their rays cached between calls (same camera, any pose).
CACHED_RAYS = 1 << 21
#: Hits closer than this to the camera centre are ignored (metres).
NEAR_M = 1e-6


@dataclass(frozen=True)
class Rendering:
    """What the bounding-box camera sees from one pose.

    Attributes
    ----------
    labels : ndarray, shape (height * s, width * s), int32
        Fruit index, :data:`BACKGROUND` (-1) or :data:`OCCLUDER` (-2) per (sub-)pixel.
    boxes_xyxy : ndarray, shape (M, 4), float64, pixels
        Box of each fruit's visible pixels (edge convention); NaN rows for fruit that are not visible.
    visible_px : ndarray, shape (M,), float64
        Visible area of each fruit in pixels (sub-pixel samples / ``s**2``).
    supersample : int
        ``s``, sub-pixel rays per pixel along each axis.
    """

    labels: NDArray[np.int32]
    boxes_xyxy: NDArray[np.float64]
    visible_px: NDArray[np.float64]
    supersample: int = 1

    @property
    def visible(self) -> NDArray[np.bool_]:
        """Shape (M,): True where the fruit has a box."""
        return np.isfinite(self.boxes_xyxy[:, 0])


def render(
    scene: Scene,
    camera: Camera,
    T_base_optical: ArrayLike,
    *,
    supersample: int = 1,
    min_pixels: float = 1.0,
    tile: int = TILE,
) -> Rendering:
    """Ray-cast a scene and box every visible fruit.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        Intrinsics (lens distortion is honoured through :meth:`Camera.rays`).
    T_base_optical : array_like, shape (4, 4)
        True camera pose, the optical frame expressed in the base frame.
    supersample : int
        Sub-pixel rays per pixel along each axis (1 = one ray per pixel centre).
    min_pixels : float
        A fruit needs at least this visible area (pixels) to get a box.
    tile : int
        Side of the image tiles intersected at a time, (sub-)pixels.

    Returns
    -------
    Rendering

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> from monovisual3d.sim.scene import Scene, Sphere
    >>> scene = Scene((Sphere(np.array([1.0, 0.0, 0.0]), 0.1),))
    >>> cam = Camera(64, 48, 50.0, 50.0, 32.0, 24.0)
    >>> r = render(scene, cam, look_at([0, 0, 0], [1, 0, 0]))
    >>> r.boxes_xyxy
    array([[27., 19., 37., 29.]])
    """
    labels = label_image(scene, camera, T_base_optical, supersample=supersample, tile=tile)
    boxes, counts = boxes_from_labels(labels, len(scene.fruits), supersample=supersample)
    visible_px = counts / supersample**2
    if min_pixels > 0:
        boxes[visible_px < min_pixels] = np.nan
    return Rendering(labels, boxes, visible_px, supersample)


def label_image(
    scene: Scene, camera: Camera, T_base_optical: ArrayLike, *, supersample: int = 1, tile: int = TILE
) -> NDArray[np.int32]:
    """Label image of a scene by exact ray casting (vectorised over the rays of image tiles).

    Parameters
    ----------
    scene : Scene
    camera : Camera
    T_base_optical : array_like, shape (4, 4)
    supersample : int, sub-pixel rays per pixel along each axis
    tile : int, side of the square tiles intersected at a time, (sub-)pixels

    Returns
    -------
    labels : ndarray, shape (height * supersample, width * supersample), int32
        Fruit index (0..M-1), :data:`BACKGROUND` or :data:`OCCLUDER`.
    """
    s = _check_supersample(supersample)
    if not (is_int(tile) and tile > 0):
        raise InputError(f"tile: got {tile!r}, expected a positive integer")
    geometry = _OpticalGeometry.from_scene(scene, T_base_optical)
    W, H = camera.width * s, camera.height * s
    rays = _pixel_rays(camera, s).reshape(H, W, 3) if W * H <= CACHED_RAYS else None
    labels = np.full((H, W), BACKGROUND, dtype=np.int32)
    for r0 in range(0, H, tile):
        for c0 in range(0, W, tile):
            r1, c1 = min(r0 + tile, H), min(c0 + tile, W)
            if rays is not None:
                d = rays[r0:r1, c0:c1].reshape(-1, 3)
            else:
                u = (np.arange(c0, c1) + 0.5) / s
                v = (np.arange(r0, r1) + 0.5) / s
                d = camera.rays(np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2))
            local = geometry.within_cone(d)
            if local.n_primitives:
                labels[r0:r1, c0:c1] = local.nearest_labels(d).reshape(r1 - r0, c1 - c0)
    return labels


@functools.lru_cache(maxsize=2)
def _pixel_rays(camera: Camera, supersample: int) -> NDArray[np.float64]:
    """Unit rays (H * W, 3), optical frame, through every (sub-)pixel centre in row-major order (read-only)."""
    W, H = camera.width * supersample, camera.height * supersample
    u = (np.arange(W) + 0.5) / supersample
    v = (np.arange(H) + 0.5) / supersample
    uv = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    d = camera.rays(uv)
    d.setflags(write=False)
    return d


def boxes_from_labels(
    labels: NDArray[np.integer], n_fruit: int, *, supersample: int = 1
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Per-fruit boxes of a label image, in pixels of the original (not supersampled) image.

    Parameters
    ----------
    labels : ndarray, shape (H, W), int, fruit index or negative
    n_fruit : int, M
    supersample : int, ``s`` the label image was rendered with

    Returns
    -------
    boxes_xyxy : ndarray, shape (M, 4), float64, pixels, NaN rows for absent fruit
    counts : ndarray, shape (M,), int64, labelled (sub-)pixels per fruit

    Examples
    --------
    >>> labels = np.full((4, 5), -1)
    >>> labels[1:3, 2] = 0
    >>> boxes_from_labels(labels, 2)[0]
    array([[ 2.,  1.,  3.,  3.],
           [nan, nan, nan, nan]])
    """
    s = _check_supersample(supersample)
    labels = np.asarray(labels)
    if labels.ndim != 2:
        raise InputError(f"labels: expected a 2D image, got shape {labels.shape}")
    boxes = np.full((n_fruit, 4), np.nan)
    flat = labels.ravel()
    fruit = flat >= 0
    if np.any(flat[fruit] >= n_fruit):
        raise InputError(f"labels: contains fruit index {int(flat.max())}, expected < {n_fruit}")
    idx = np.flatnonzero(fruit)
    lab = flat[idx]
    counts = np.bincount(lab, minlength=n_fruit).astype(np.int64)
    if idx.size:
        W = labels.shape[1]
        cols, rows = idx % W, idx // W
        big = np.iinfo(np.int64).max
        for values, lo_col, hi_col in ((cols, 0, 2), (rows, 1, 3)):
            lo = np.full(n_fruit, big)
            hi = np.full(n_fruit, -1)
            np.minimum.at(lo, lab, values)
            np.maximum.at(hi, lab, values)
            seen = counts > 0
            boxes[seen, lo_col] = lo[seen] / s
            boxes[seen, hi_col] = (hi[seen] + 1) / s
    return boxes, counts


# ---------------------------------------------------------------------- geometry in the optical frame
@dataclass(frozen=True)
class _OpticalGeometry:
    """The scene's primitives in the optical frame, as arrays."""

    sphere_c: NDArray[np.float64]  # (M, 3)
    sphere_r: NDArray[np.float64]  # (M,)
    ell_c: NDArray[np.float64]  # (E, 3)
    ell_M: NDArray[np.float64]  # (E, 3, 3) diag(1 / semi-axes) R_optical_ellipsoid^T: optical offset -> unit sphere
    ell_r: NDArray[np.float64]  # (E,) largest semi-axis (bounding sphere)
    ell_id: NDArray[np.int64]  # (E,) scene index of each ellipsoid
    leaf_c: NDArray[np.float64]  # (L, 3)
    leaf_u: NDArray[np.float64]  # (L, 3) unit
    leaf_v: NDArray[np.float64]  # (L, 3) unit
    leaf_half: NDArray[np.float64]  # (L, 2)
    stem_s: NDArray[np.float64]  # (S, 3) start
    stem_a: NDArray[np.float64]  # (S, 3) unit axis
    stem_len: NDArray[np.float64]  # (S,)
    stem_r: NDArray[np.float64]  # (S,)
    fruit_id: NDArray[np.int64]  # (M,) scene index of each sphere

    @property
    def n_primitives(self) -> int:
        return len(self.sphere_r) + len(self.ell_r) + len(self.leaf_half) + len(self.stem_r)

    def bounding_spheres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres (K, 3) and radii (K,) of spheres that enclose each primitive (spheres, ellipsoids, leaves, stems)."""
        centres = np.concatenate(
            [self.sphere_c, self.ell_c, self.leaf_c, self.stem_s + 0.5 * self.stem_len[:, None] * self.stem_a]
        )
        radii = np.concatenate(
            [
                self.sphere_r,
                self.ell_r,
                np.hypot(self.leaf_half[:, 0], self.leaf_half[:, 1]),
                np.hypot(0.5 * self.stem_len, self.stem_r),
            ]
        )
        return centres, radii

    def within_cone(self, d: NDArray[np.float64]) -> _OpticalGeometry:
        """The primitives whose bounding spheres meet the cone around the unit rays ``d`` (N, 3)."""
        if self.n_primitives == 0:
            return self
        axis = d.sum(axis=0)
        axis /= np.linalg.norm(axis)
        half = math.acos(min(1.0, float(np.min(d @ axis))))
        centres, radii = self.bounding_spheres()
        dist = np.linalg.norm(centres, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            angle = np.arccos(np.clip(centres @ axis / dist, -1.0, 1.0))
            spread = np.arcsin(np.clip(radii / dist, 0.0, 1.0))
        keep = (dist <= radii) | (angle - spread <= half + 1e-9)
        m, n_ell, n_leaf = len(self.sphere_r), len(self.ell_r), len(self.leaf_half)
        ks, ke = keep[:m], keep[m : m + n_ell]
        kl, kt = keep[m + n_ell : m + n_ell + n_leaf], keep[m + n_ell + n_leaf :]
        return _OpticalGeometry(
            self.sphere_c[ks],
            self.sphere_r[ks],
            self.ell_c[ke],
            self.ell_M[ke],
            self.ell_r[ke],
            self.ell_id[ke],
            self.leaf_c[kl],
            self.leaf_u[kl],
            self.leaf_v[kl],
            self.leaf_half[kl],
            self.stem_s[kt],
            self.stem_a[kt],
            self.stem_len[kt],
            self.stem_r[kt],
            self.fruit_id[ks],
        )

    @classmethod
    def from_scene(cls, scene: Scene, T_base_optical: ArrayLike) -> _OpticalGeometry:
        T_optical_base = invert_transform(check_transform(T_base_optical, where="T_base_optical"))
        R = T_optical_base[:3, :3]
        is_ell = np.array([isinstance(f, EllipsoidFruit) for f in scene.fruits], dtype=bool)
        ells = [f for f in scene.fruits if isinstance(f, EllipsoidFruit)]
        ell_R = np.array([R @ f.rotation for f in ells]).reshape(-1, 3, 3)  # R_optical_ellipsoid
        ell_s = np.array([f.semi_axes for f in ells], dtype=float).reshape(-1, 3)
        leaves = [o for o in scene.occluders if isinstance(o, Leaf)]
        stems = [o for o in scene.occluders if isinstance(o, Stem)]
        leaf_u = np.array([_unit(lf.axis_u, "leaf.axis_u") for lf in leaves]).reshape(-1, 3)
        leaf_v = np.array([_unit(lf.axis_v, "leaf.axis_v") for lf in leaves]).reshape(-1, 3)
        if leaves and np.any(np.abs(np.sum(leaf_u * leaf_v, axis=1)) > 1e-6):
            raise InputError("leaf: axis_u and axis_v are not orthogonal, expected a rectangle")
        starts = np.array([st.start for st in stems], dtype=float).reshape(-1, 3)
        ends = np.array([st.end for st in stems], dtype=float).reshape(-1, 3)
        lengths = np.linalg.norm(ends - starts, axis=1)
        if np.any(lengths <= 0):
            raise InputError("stem: start and end coincide, expected a cylinder of positive length")
        return cls(
            sphere_c=transform_points(T_optical_base, scene.centres[~is_ell]),
            sphere_r=scene.radii[~is_ell].reshape(-1),
            ell_c=transform_points(T_optical_base, scene.centres[is_ell]),
            ell_M=np.swapaxes(ell_R, 1, 2) / ell_s[:, :, None],
            ell_r=ell_s.max(axis=1, initial=0.0) if len(ells) else np.zeros(0),
            ell_id=np.flatnonzero(is_ell).astype(np.int64),
            leaf_c=transform_points(T_optical_base, np.array([lf.centre for lf in leaves]).reshape(-1, 3)),
            leaf_u=leaf_u @ R.T,
            leaf_v=leaf_v @ R.T,
            leaf_half=np.array([lf.half_size for lf in leaves], dtype=float).reshape(-1, 2),
            stem_s=transform_points(T_optical_base, starts),
            stem_a=((ends - starts) / lengths[:, None].clip(1e-300)) @ R.T,
            stem_len=lengths,
            stem_r=np.array([st.radius for st in stems], dtype=float).reshape(-1),
            fruit_id=np.flatnonzero(~is_ell).astype(np.int64),
        )

    def nearest_labels(self, d: NDArray[np.float64]) -> NDArray[np.int32]:
        """Label of the nearest hit along unit rays ``d`` (N, 3) from the origin."""
        t = np.concatenate([self.sphere_t(d), self.ellipsoid_t(d), self.leaf_t(d), self.stem_t(d)], axis=1)
        if t.shape[1] == 0:
            return np.full(len(d), BACKGROUND, dtype=np.int32)
        fruit = np.concatenate([self.fruit_id, self.ell_id])
        label_of = np.concatenate([fruit, np.full(t.shape[1] - len(fruit), OCCLUDER)]).astype(np.int32)
        best = np.argmin(t, axis=1)
        out = label_of[best]
        out[~np.isfinite(t[np.arange(len(d)), best])] = BACKGROUND
        return out

    def sphere_t(self, d: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance to the first sphere hit, shape (N, M), inf for a miss."""
        c, r = self.sphere_c, self.sphere_r
        b = d @ c.T  # (N, M): t of the closest approach
        cc = np.sum(c * c, axis=1) - r * r  # (M,)
        disc = b * b - cc
        with np.errstate(invalid="ignore"):
            root = np.sqrt(disc)
        t_near = b - root
        t_far = b + root
        t = np.where(t_near > NEAR_M, t_near, t_far)
        return np.where((disc >= 0) & (t > NEAR_M), t, np.inf)

    def ellipsoid_t(self, d: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance to the first ellipsoid hit, shape (N, E), inf for a miss.

        In each ellipsoid's unit-sphere coordinates the ray is ``t a - w`` (``a = M d``, ``w = M c``)
        and hits where ``|t a - w| = 1``.
        """
        a = np.einsum("eij,nj->nei", self.ell_M, d)  # (N, E, 3)
        w = np.einsum("eij,ej->ei", self.ell_M, self.ell_c)  # (E, 3)
        A = np.sum(a * a, axis=-1)
        B = np.einsum("nei,ei->ne", a, w)
        C = np.sum(w * w, axis=-1) - 1.0
        disc = B * B - A * C
        with np.errstate(invalid="ignore", divide="ignore"):
            root = np.sqrt(disc)
            t_near = (B - root) / A
            t_far = (B + root) / A
        t = np.where(t_near > NEAR_M, t_near, t_far)
        return np.where((disc >= 0) & (t > NEAR_M), t, np.inf)

    def leaf_t(self, d: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance to each rectangle, shape (N, L), inf for a miss."""
        n = np.cross(self.leaf_u, self.leaf_v)  # (L, 3)
        dn = d @ n.T  # (N, L)
        cn = np.sum(self.leaf_c * n, axis=1)  # (L,)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = cn / dn
        # in-plane coordinates of the hit relative to the leaf centre
        a = t * (d @ self.leaf_u.T) - np.sum(self.leaf_c * self.leaf_u, axis=1)
        b = t * (d @ self.leaf_v.T) - np.sum(self.leaf_c * self.leaf_v, axis=1)
        inside = (np.abs(a) <= self.leaf_half[:, 0]) & (np.abs(b) <= self.leaf_half[:, 1]) & (t > NEAR_M)
        return np.where(inside, t, np.inf)

    def stem_t(self, d: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance to each finite cylinder (side or end caps), shape (N, S), inf for a miss."""
        s, a, length, rho = self.stem_s, self.stem_a, self.stem_len, self.stem_r
        w = -s  # ray origin (0) minus cylinder start, (S, 3)
        da = d @ a.T  # (N, S)
        wa = np.sum(w * a, axis=1)  # (S,)
        dw = d @ w.T  # (N, S)
        A = 1.0 - da * da
        B = 2.0 * (dw - da * wa)
        C = np.sum(w * w, axis=1) - wa * wa - rho * rho
        disc = B * B - 4.0 * A * C
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt(disc)
            best = np.full(da.shape, np.inf)
            for sign in (-1.0, 1.0):
                t = (-B + sign * root) / (2.0 * A)
                h = wa + t * da  # axial coordinate of the hit
                ok = (disc >= 0) & (A > 1e-12) & (t > NEAR_M) & (h >= 0) & (h <= length)
                best = np.where(ok & (t < best), t, best)
            for offset in (np.zeros_like(length), length):  # caps at the start and at the end
                t = (offset - wa) / da
                radial2 = np.sum(w * w, axis=1) + 2 * t * dw + t * t - (wa + t * da) ** 2
                ok = (t > NEAR_M) & (radial2 <= rho * rho)
                best = np.where(ok & (t < best), t, best)
        return best


def label_image_reference(scene: Scene, camera: Camera, T_base_optical: ArrayLike, *, supersample: int = 1) -> NDArray[np.int32]:
    """Readable per-ray reference of :func:`label_image` (slow; for tests on small images)."""
    s = _check_supersample(supersample)
    T_optical_base = invert_transform(check_transform(T_base_optical, where="T_base_optical"))
    R, p = T_optical_base[:3, :3], T_optical_base[:3, 3]
    objects: list[tuple[int, object]] = [(i, f) for i, f in enumerate(scene.fruits)]
    objects += [(OCCLUDER, o) for o in scene.occluders]
    out = np.full((camera.height * s, camera.width * s), BACKGROUND, dtype=np.int32)
    u = (np.arange(camera.width * s) + 0.5) / s
    v = (np.arange(camera.height * s) + 0.5) / s
    rays = camera.rays(np.stack(np.meshgrid(u, v), axis=-1))  # (H, W, 3)
    for row in range(camera.height * s):
        for col in range(camera.width * s):
            d = rays[row, col]
            nearest = math.inf
            for label, obj in objects:
                t = _ray_hit_reference(d, obj, R, p)
                if t < nearest:
                    nearest, out[row, col] = t, label
    return out


def _ray_hit_reference(d: NDArray[np.float64], obj: object, R: NDArray[np.float64], p: NDArray[np.float64]) -> float:
    """Distance from the camera to the first hit of ray ``d`` (optical) on one object, inf for a miss."""
    candidates: list[float] = []
    if isinstance(obj, Leaf):
        c, u, v = R @ obj.centre + p, R @ _unit(obj.axis_u, ""), R @ _unit(obj.axis_v, "")
        n = np.cross(u, v)
        if abs(d @ n) > 1e-15:
            t = (c @ n) / (d @ n)
            q = t * d - c
            if abs(q @ u) <= obj.half_size[0] and abs(q @ v) <= obj.half_size[1]:
                candidates.append(t)
    elif isinstance(obj, Stem):
        start, end = R @ obj.start + p, R @ obj.end + p
        axis = (end - start) / np.linalg.norm(end - start)
        length = float(np.linalg.norm(end - start))
        # side: |(t d - start) x axis| = r, solve the quadratic in t
        d_perp = d - (d @ axis) * axis
        w_perp = -start - (-start @ axis) * axis
        A, B, C = d_perp @ d_perp, 2 * d_perp @ w_perp, w_perp @ w_perp - obj.radius**2
        if A > 1e-12 and B * B - 4 * A * C >= 0:
            for t in ((-B - math.sqrt(B * B - 4 * A * C)) / (2 * A), (-B + math.sqrt(B * B - 4 * A * C)) / (2 * A)):
                if 0 <= (t * d - start) @ axis <= length:
                    candidates.append(t)
        for cap in (start, end):
            if abs(d @ axis) > 1e-15:
                t = (cap @ axis) / (d @ axis)
                if np.linalg.norm(t * d - cap) <= obj.radius:
                    candidates.append(t)
    elif isinstance(obj, EllipsoidFruit):
        M = np.diag(1.0 / obj.semi_axes) @ (R @ obj.rotation).T  # optical offset -> unit sphere
        a, w = M @ d, M @ (R @ obj.centre + p)
        A, B, C = a @ a, a @ w, w @ w - 1.0
        if B * B - A * C >= 0:
            candidates += [(B - math.sqrt(B * B - A * C)) / A, (B + math.sqrt(B * B - A * C)) / A]
    else:  # a sphere
        c = R @ obj.centre + p  # type: ignore[attr-defined]
        b, cc = d @ c, c @ c - obj.radius**2  # type: ignore[attr-defined]
        if b * b - cc >= 0:
            candidates += [b - math.sqrt(b * b - cc), b + math.sqrt(b * b - cc)]
    hits = [t for t in candidates if t > NEAR_M]
    return min(hits) if hits else math.inf


def _unit(v: ArrayLike, where: str) -> NDArray[np.float64]:
    v = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(v))
    if not n > 0:
        raise InputError(f"{where}: zero vector, expected a direction")
    return v / n


def _check_supersample(supersample: int) -> int:
    if not is_int(supersample) or not 1 <= supersample <= 16:
        raise InputError(f"--supersample (supersample): got {supersample!r}, expected an integer from 1 to 16")
    return int(supersample)
