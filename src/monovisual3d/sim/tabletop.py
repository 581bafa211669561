"""A table top of lying boxes and standing bottles seen from one side: a simulated counterpart of a real multi-view set.

Aldoma's table-top set (``monovisual3d bench real``) has lying boxes and upright bottles seen by a hand-held camera.
:func:`tabletop_scene` draws one afresh per seed: four objects lying on the table (ellipsoids 240 x 110 x 120 mm with
a random yaw, or with ``cuboids`` boxes of the same half-sides) and two bottles standing (cylinders of radius 40 mm
and height 180 mm), their footprints apart in a 0.6 m square; 8 views at random azimuths over 180 degrees (so some
stand close together, as a hand-held or arm-held sequence does), 0.9-1.1 m from the table's middle and 35-40 degrees
above it, 640 x 480 (:func:`tabletop_camera`). Each box is the object's whole silhouette box, exact (no noise), and
every box lies inside its image (a draw that leaves one is drawn again).

The table is the base frame's z = 0 plane, its middle the origin; the cameras stand on its -x side.

Examples
--------
>>> import numpy as np
>>> table = tabletop_scene(np.random.default_rng(800))
>>> table.centres_base.shape, table.boxes_xyxy.shape, table.T_base_optical.shape
((6, 3), (8, 6, 4), (8, 4, 4))
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError
from ..frames import look_at
from ..geometry.ellipsoid import ellipsoid_bbox
from ..geometry.orientation import rotation_upright
from ..geometry.solids import cuboid_bbox, cylinder_bbox

#: The lying objects' semi-axes (metres), the bottles' radius and half-height (metres); how many of each.
BOX_HALF_SIDES_M, BOTTLE_R_M, BOTTLE_HALF_H_M = (0.12, 0.055, 0.06), 0.04, 0.09
N_LYING, N_BOTTLES = 4, 2
#: The objects' centres lie in a square of this half-side (metres); their footprints (circles of these radii, metres)
#: do not overlap.
HALF_TABLE_M = 0.3
BOX_FOOTPRINT_M, BOTTLE_FOOTPRINT_M = float(np.hypot(*BOX_HALF_SIDES_M[:2])), BOTTLE_R_M
#: The views: how many, their azimuths uniform over this arc (degrees), distance (metres) and elevation (degrees)
#: ranges, and how far from the table's middle each one aims (metres, per axis).
N_VIEWS, ARC_DEG, DISTANCE_M, ELEVATION_DEG, AIM_JITTER_M = 8, 180.0, (0.9, 1.1), (35.0, 40.0), 0.03


def tabletop_camera() -> Camera:
    """The table top's camera: 640 x 480, fx = fy = 528 px (Aldoma's), principal point at the image's centre.

    Examples
    --------
    >>> tabletop_camera().fx
    528.0
    """
    return Camera(640, 480, 528.0, 528.0, 319.5, 239.5)


@dataclass(frozen=True, eq=False)
class TableTop:
    """One table top and its views.

    Attributes
    ----------
    centres_base : ndarray, shape (N, 3), metres, base frame: the lying objects first, then the bottles
    boxes_xyxy : ndarray, shape (K, N, 4), pixels, each object's exact whole-silhouette box in each view
    T_base_optical : ndarray, shape (K, 4, 4)
    """

    centres_base: NDArray[np.float64]
    boxes_xyxy: NDArray[np.float64]
    T_base_optical: NDArray[np.float64]


def _centres(rng: np.random.Generator) -> NDArray[np.float64]:
    """Centres (N, 3) of :data:`N_LYING` lying objects then :data:`N_BOTTLES` bottles whose footprints do not overlap."""
    centres: list[NDArray[np.float64]] = []
    reach = [BOX_FOOTPRINT_M] * N_LYING + [BOTTLE_FOOTPRINT_M] * N_BOTTLES
    while len(centres) < N_LYING + N_BOTTLES:
        xy, r = rng.uniform(-HALF_TABLE_M, HALF_TABLE_M, 2), reach[len(centres)]
        if all(np.hypot(*(xy - c[:2])) >= r + r_c for c, r_c in zip(centres, reach)):
            z = BOX_HALF_SIDES_M[2] if len(centres) < N_LYING else BOTTLE_HALF_H_M
            centres.append(np.array([xy[0], xy[1], z]))
    return np.array(centres)


def _views(rng: np.random.Generator, azimuths_deg: ArrayLike | None) -> NDArray[np.float64]:
    """Poses (K, 4, 4) on the table's -x side: :data:`N_VIEWS` random azimuths over :data:`ARC_DEG`, or ``azimuths_deg``."""
    if azimuths_deg is None:
        azimuths = np.sort(rng.uniform(-np.radians(ARC_DEG) / 2, np.radians(ARC_DEG) / 2, N_VIEWS))
    else:
        azimuths = np.radians(np.asarray(azimuths_deg, dtype=float))
    poses = []
    for az in azimuths:
        d, e = rng.uniform(*DISTANCE_M), np.radians(rng.uniform(*ELEVATION_DEG))
        eye = d * np.array([-np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)])
        poses.append(look_at(eye, rng.uniform(-AIM_JITTER_M, AIM_JITTER_M, 3)))
    return np.array(poses)


def tabletop_scene(
    rng: np.random.Generator | int | None, azimuths_deg: ArrayLike | None = None, *, cuboids: bool = False
) -> TableTop:
    """A table top whose boxes all lie inside the images (see the module's docstring).

    Parameters
    ----------
    rng : numpy Generator, seed or None; draws, in order: the centres, the views, the lying objects' yaws (again from
        the centres where a box left an image)
    azimuths_deg : array_like, shape (K,), degrees, or None: the views' azimuths (None: :data:`N_VIEWS` drawn)
    cuboids : bool, the lying objects are cuboids of the same half-sides (as real boxes are), not ellipsoids; the same
        draws

    Returns
    -------
    TableTop

    Examples
    --------
    >>> table = tabletop_scene(0, azimuths_deg=[-30.0, -27.0, 60.0], cuboids=True)
    >>> table.boxes_xyxy.shape
    (3, 6, 4)
    """
    if azimuths_deg is not None and np.ndim(azimuths_deg) != 1:
        raise InputError(f"azimuths_deg: got shape {np.shape(azimuths_deg)}, expected (K,) degrees")
    rng = np.random.default_rng(rng)
    camera = tabletop_camera()
    lying = cuboid_bbox if cuboids else partial(ellipsoid_bbox, clip=False)
    while True:
        centres = _centres(rng)
        T = _views(rng, azimuths_deg)
        boxes = [lying(camera, T, c, BOX_HALF_SIDES_M, rotation_upright(rng.uniform(0, np.pi))) for c in centres[:N_LYING]]
        boxes += [cylinder_bbox(camera, T, c, BOTTLE_R_M, BOTTLE_HALF_H_M, rotation_upright(0.0)) for c in centres[N_LYING:]]
        B = np.stack(boxes, axis=1)
        if np.all(B[..., :2] >= 0) and np.all(B[..., 2] <= camera.width) and np.all(B[..., 3] <= camera.height):
            return TableTop(centres, B, T)
