"""Containers on a robot arm's bench: upright cuboids and cylinders (and a flat tray) seen from views on an arc.

The simulated counterpart of issue 20's hidden robot-arm scenes, with the exact boxes of solids (a detector's box
around a solid is the box of its whole silhouette, not of an ellipsoid's):

- :data:`TARGET_BASE` and :func:`arm_camera`: where the scenes stand (base frame, z up) and the camera that sees them
  (1280 x 720 or 640 x 480, 69 degrees wide);
- :func:`arc_views`: 3 views over 120 degrees or 8 over 180 degrees of azimuth on the scene's -x side, 0.5-0.7 m away,
  at one elevation or one per view, each aimed within 2 cm of the scene;
- :class:`UprightSolid`: one upright cuboid (random yaw), cylinder or ellipsoid and its exact boxes;
- :func:`container_pair` and :class:`ContainerScene`: two containers side by side (by default 5 x 5 x 12 cm, 57 mm
  apart), with a flat 200 x 160 x 30 mm tray behind them or under them;
- :func:`detector_boxes`: a scene's boxes as a detector draws them (whole silhouettes or visible parts, box noise);
- :func:`reported_poses`: the views' poses as an arm reports them (a pose error per view, a hand-eye error per scene).

Every function that draws takes ``rng`` (a numpy Generator, a seed or None) and draws in a fixed order, so that a seed
gives the same scene, boxes and poses from one version to the next (the experiments' numbers depend on it).

Examples
--------
>>> import numpy as np
>>> scene = container_pair(np.random.default_rng(500), "cuboid", tray="behind")
>>> scene.centres_base.shape, scene.T_base_optical.shape, [s.kind for s in scene.solids]
((3, 3), (8, 4, 4), ['cuboid', 'cuboid', 'cuboid'])
>>> boxes, shown = detector_boxes(scene, arm_camera(), 0.005, rng=0)
>>> boxes.shape, bool(shown.all())
((8, 3, 4), True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..errors import InputError
from ..frames import look_at
from ..geometry.ellipsoid import ellipsoid_bbox
from ..geometry.orientation import rotation_upright
from ..geometry.solids import cuboid_bbox, cylinder_bbox
from .noise import hand_eye_offset, perturb_boxes, perturb_pose, visible_part_boxes, wholly_hidden

#: The middle of the scenes, metres, base frame (z up); each scene's middle is drawn within
#: :data:`MIDDLE_JITTER_M` of it per axis.
TARGET_BASE = (0.6, 0.0, 0.3)
MIDDLE_JITTER_M = 0.01
#: Horizontal field of view of :func:`arm_camera`, degrees.
HFOV_DEG = 69.0
#: Azimuths (degrees) of the views of :func:`arc_views`, by number of views: 120 degrees for 3, 180 for 8.
ARC_AZIMUTHS_DEG = {3: tuple(np.linspace(-60.0, 60.0, 3).tolist()), 8: tuple(np.linspace(-90.0, 90.0, 8).tolist())}
#: Distance range of the views from the scene (metres) and how far from its middle each one aims (metres, per axis).
DISTANCE_M = (0.5, 0.7)
AIM_JITTER_M = 0.02
#: The issue's containers: half-width (half-side or radius) and half-height, metres; their centres' spacing, metres.
HALF_WIDTH_M, HALF_HEIGHT_M, SPACING_M = 0.025, 0.06, 0.057
#: The flat tray: half-sides (metres), and its centre's offset from the pair's middle when it stands behind them
#: (7 cm farther from the cameras, 4.5 cm lower), metres.
TRAY_HALF_SIDES_M = (0.10, 0.08, 0.015)
TRAY_OFFSET_M = (0.07, 0.0, -0.045)
#: The kinds of :class:`UprightSolid` and where :func:`container_pair` puts a tray.
KINDS = ("cuboid", "cylinder", "ellipsoid")
TRAY_PLACES = ("behind", "under")


def arm_camera(width: int = 1280, height: int = 720) -> Camera:
    """The scenes' camera: ``width`` x ``height`` pixels, :data:`HFOV_DEG` wide, no distortion.

    Examples
    --------
    >>> cam = arm_camera(640, 480)
    >>> (cam.width, cam.height)
    (640, 480)
    """
    return Camera.from_hfov(width, height, HFOV_DEG)


def scene_middle(rng: np.random.Generator | int | None = None) -> NDArray[np.float64]:
    """A scene's middle (3,), metres, base frame: :data:`TARGET_BASE` moved by up to :data:`MIDDLE_JITTER_M` per axis.

    Examples
    --------
    >>> bool(np.all(np.abs(scene_middle(0) - TARGET_BASE) <= MIDDLE_JITTER_M))
    True
    """
    rng = np.random.default_rng(rng)
    return np.asarray(TARGET_BASE) + rng.uniform(-MIDDLE_JITTER_M, MIDDLE_JITTER_M, 3)


def arc_views(
    n_views: int,
    elevation_deg: float | ArrayLike,
    centre_base: ArrayLike,
    rng: np.random.Generator | int | None = None,
) -> NDArray[np.float64]:
    """Poses of views on an arc on the -x side of ``centre_base``, :data:`DISTANCE_M` away, aimed near it.

    Parameters
    ----------
    n_views : int, 3 (azimuths -60, 0, 60 degrees) or 8 (-90 to 90 degrees), see :data:`ARC_AZIMUTHS_DEG`
    elevation_deg : float or array_like, shape (n_views,), degrees above the horizontal: one for every view, or one each
    centre_base : array_like, shape (3,), metres, base frame, what the views look at
    rng : numpy Generator, seed or None; per view, the distance then the aim point's offset (within
        :data:`AIM_JITTER_M` per axis) are drawn

    Returns
    -------
    T_base_optical : ndarray, shape (n_views, 4, 4)

    Examples
    --------
    >>> T = arc_views(3, 30.0, TARGET_BASE, rng=0)
    >>> T.shape, bool(np.all(T[:, 2, 3] > TARGET_BASE[2]))  # from 30 degrees above
    ((3, 4, 4), True)
    """
    if n_views not in ARC_AZIMUTHS_DEG:
        raise InputError(f"n_views: got {n_views!r}, expected one of {sorted(ARC_AZIMUTHS_DEG)}")
    rng = np.random.default_rng(rng)
    centre = np.asarray(centre_base, dtype=float)
    elevations = np.radians(np.broadcast_to(np.asarray(elevation_deg, dtype=float), (n_views,)))
    poses = []
    for az, e in zip(np.radians(ARC_AZIMUTHS_DEG[n_views]), elevations):
        d = rng.uniform(*DISTANCE_M)
        p = centre + d * np.array([-np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)])
        poses.append(look_at(p, centre + rng.uniform(-AIM_JITTER_M, AIM_JITTER_M, 3)))
    return np.array(poses)


@dataclass(frozen=True)
class UprightSolid:
    """An upright solid: its kind, size and yaw about base z.

    Attributes
    ----------
    kind : {"cuboid", "cylinder", "ellipsoid"}
    semi_axes_m : tuple of 3 floats, metres: a cuboid's half-sides, a cylinder's (radius, radius, half-height), an
        ellipsoid's semi-axes (x, y before the yaw, then z)
    yaw_rad : float, radians, about base z
    """

    kind: str
    semi_axes_m: tuple[float, float, float]
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError(f"kind: got {self.kind!r}, expected one of {list(KINDS)}")
        if len(self.semi_axes_m) != 3 or not all(math.isfinite(s) and s > 0 for s in self.semi_axes_m):
            raise InputError(f"semi_axes_m: got {self.semi_axes_m!r}, expected three positive lengths in metres")

    @classmethod
    def draw(
        cls, kind: str, half_width_m: float, half_height_m: float, rng: np.random.Generator | int | None = None
    ) -> UprightSolid:
        """A container: a cuboid of square section (its yaw drawn in [0, 90) degrees), or a cylinder or an ellipsoid
        of round section (yaw 0, nothing drawn), ``half_width_m`` wide (half-side or radius) and ``half_height_m`` high.

        Examples
        --------
        >>> UprightSolid.draw("cylinder", 0.025, 0.06)
        UprightSolid(kind='cylinder', semi_axes_m=(0.025, 0.025, 0.06), yaw_rad=0.0)
        """
        yaw = float(np.random.default_rng(rng).uniform(0.0, np.pi / 2)) if kind == "cuboid" else 0.0
        return cls(kind, (half_width_m, half_width_m, half_height_m), yaw)

    def boxes(self, camera: Camera, T_base_optical: ArrayLike, centre_base: ArrayLike) -> NDArray[np.float64]:
        """The exact boxes of the whole silhouette, unclipped.

        Parameters
        ----------
        camera : Camera
        T_base_optical : array_like, shape (K, 4, 4)
        centre_base : array_like, shape (3,), metres, base frame

        Returns
        -------
        bbox_xyxy : ndarray, shape (K, 4), pixels

        Examples
        --------
        >>> solid = UprightSolid("cuboid", (0.025, 0.025, 0.06))
        >>> solid.boxes(arm_camera(), arc_views(3, 0.0, TARGET_BASE, rng=0), TARGET_BASE).shape
        (3, 4)
        """
        R = rotation_upright(self.yaw_rad)
        if self.kind == "cylinder":
            return cylinder_bbox(camera, T_base_optical, centre_base, self.semi_axes_m[0], self.semi_axes_m[2], R)
        if self.kind == "cuboid":
            return cuboid_bbox(camera, T_base_optical, centre_base, list(self.semi_axes_m), R)
        return ellipsoid_bbox(camera, T_base_optical, centre_base, list(self.semi_axes_m), R, clip=False)


@dataclass(frozen=True, eq=False)
class ContainerScene:
    """Solids and the views that see them.

    Attributes
    ----------
    centres_base : ndarray, shape (N, 3), metres, base frame: the containers first, then the tray (if any)
    solids : tuple of N :class:`UprightSolid`, in the same order
    T_base_optical : ndarray, shape (K, 4, 4), the true poses of the views
    """

    centres_base: NDArray[np.float64]
    solids: tuple[UprightSolid, ...]
    T_base_optical: NDArray[np.float64]

    def boxes(self, camera: Camera) -> NDArray[np.float64]:
        """Exact boxes of the whole silhouettes, ``bbox_xyxy`` (K, N, 4), pixels, unclipped."""
        return np.stack([s.boxes(camera, self.T_base_optical, c) for s, c in zip(self.solids, self.centres_base)], axis=1)

    def depths(self) -> NDArray[np.float64]:
        """Depth (K, N) of each centre along each view's optical axis, metres."""
        T_optical_base = np.linalg.inv(self.T_base_optical)
        return np.einsum("kj,nj->kn", T_optical_base[:, 2, :3], self.centres_base) + T_optical_base[:, 2, 3:4]


def tray_offset_under(half_height_m: float) -> tuple[float, float, float]:
    """The tray's offset from the pair's middle (metres) when the pair, of this half-height, stands on it: centred under
    them, its top at their bottoms.

    Examples
    --------
    >>> tray_offset_under(0.06)
    (0.0, 0.0, -0.075)
    """
    return (0.0, 0.0, -(half_height_m + TRAY_HALF_SIDES_M[2]))


def container_pair(
    rng: np.random.Generator | int | None,
    kind: str = "cuboid",
    *,
    n_views: int = 8,
    elevation_deg: float | tuple[float, float] = 20.0,
    size_m: tuple[float, float, float] = (HALF_WIDTH_M, HALF_HEIGHT_M, SPACING_M),
    tray: str | None = None,
) -> ContainerScene:
    """Two upright containers side by side (along base y) and, with ``tray``, a flat cuboid tray; :func:`arc_views`.

    Parameters
    ----------
    rng : numpy Generator, seed or None; draws, in order: the middle (:func:`scene_middle`), the elevations (a range),
        the views, each container's yaw (cuboids), the tray's yaw (uniform in [0, 180) degrees)
    kind : {"cuboid", "cylinder", "ellipsoid"}, both containers' kind
    n_views : int, 3 or 8
    elevation_deg : float (every view) or (low, high), degrees: each view's elevation drawn uniformly in that range, as
        an arm's views mix
    size_m : (half-width, half-height, spacing of the centres), metres
    tray : None, "behind" (:data:`TRAY_OFFSET_M` from the pair's middle, its boxes overlapping theirs) or "under" (the
        pair standing on it, :func:`tray_offset_under`)

    Returns
    -------
    ContainerScene
        with 2 solids, or 3 with the tray last

    Examples
    --------
    >>> scene = container_pair(0, "cylinder", elevation_deg=(0.0, 30.0))
    >>> np.linalg.norm(scene.centres_base[1] - scene.centres_base[0]).round(3)
    np.float64(0.057)
    """
    if tray not in (None, *TRAY_PLACES):
        raise InputError(f"tray: got {tray!r}, expected None or one of {list(TRAY_PLACES)}")
    half_width, half_height, spacing = size_m
    rng = np.random.default_rng(rng)
    middle = scene_middle(rng)
    centres = np.array([middle - [0.0, spacing / 2, 0.0], middle + [0.0, spacing / 2, 0.0]])
    elevation = elevation_deg if np.isscalar(elevation_deg) else rng.uniform(*elevation_deg, n_views)  # type: ignore[misc]
    poses = arc_views(n_views, elevation, middle, rng)
    solids = [UprightSolid.draw(kind, half_width, half_height, rng) for _ in centres]
    if tray is not None:
        solids.append(UprightSolid("cuboid", TRAY_HALF_SIDES_M, float(rng.uniform(0.0, np.pi))))
        offset = tray_offset_under(half_height) if tray == "under" else TRAY_OFFSET_M
        centres = np.vstack([centres, middle + offset])
    return ContainerScene(centres, tuple(solids), poses)


def detector_boxes(
    scene: ContainerScene,
    camera: Camera,
    box_sigma: float,
    rng: np.random.Generator | int | None = None,
    *,
    visible: bool = False,
    unboxed_hidden: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The boxes a detector draws of ``scene``: whole silhouettes, or with ``visible`` the visible parts.

    Parameters
    ----------
    scene : ContainerScene
    camera : Camera
    box_sigma : float, box noise relative to the box's size (:func:`~monovisual3d.sim.noise.perturb_boxes`; 0: exact,
        nothing drawn)
    rng : numpy Generator, seed or None
    visible : bool, a farther object's box ends where a nearer one hides it
        (:func:`~monovisual3d.sim.noise.visible_part_boxes`), as a detector of visible parts draws it
    unboxed_hidden : bool, with ``visible``: an object wholly behind a nearer one, or shown as a sliver, gets no box in
        that view (:func:`~monovisual3d.sim.noise.wholly_hidden`)

    Returns
    -------
    bbox_xyxy : ndarray, shape (K, N, 4), pixels
    shown : ndarray, shape (K, N), bool, whether the object has a box in the view (all True unless ``unboxed_hidden``)

    Examples
    --------
    >>> scene = container_pair(1100, elevation_deg=0.0)
    >>> boxes, shown = detector_boxes(scene, arm_camera(), 0.0, visible=True, unboxed_hidden=True)
    >>> boxes.shape, shown.shape
    ((8, 2, 4), (8, 2))
    """
    boxes = scene.boxes(camera)
    shown = np.ones(boxes.shape[:2], dtype=bool)
    if visible:
        depths = scene.depths()
        shown = ~wholly_hidden(boxes, depths) if unboxed_hidden else shown
        boxes = visible_part_boxes(boxes, depths)
    if box_sigma > 0:
        boxes = perturb_boxes(boxes.reshape(-1, 4), box_sigma, rng).reshape(boxes.shape)
    return boxes, shown


def reported_poses(
    T_base_optical: ArrayLike,
    pose_error: tuple[float, float] = (0.0, 0.0),
    hand_eye_error: tuple[float, float] = (0.0, 0.0),
    rng: np.random.Generator | int | None = None,
) -> NDArray[np.float64]:
    """The poses an arm reports for views truly at ``T_base_optical``.

    Parameters
    ----------
    T_base_optical : array_like, shape (K, 4, 4)
    pose_error : (metres, radians), std per axis of each view's own error
        (:func:`~monovisual3d.sim.noise.perturb_pose`, drawn in every view, even when zero), as an arm's kinematics
        leave it
    hand_eye_error : (metres, radians), std per axis of one error ``E`` of the camera in its optical frame, the same in
        every view (``T_base_optical @ E``, :func:`~monovisual3d.sim.noise.hand_eye_offset`; drawn only when not zero)
    rng : numpy Generator, seed or None

    Returns
    -------
    T_base_optical_reported : ndarray, shape (K, 4, 4)

    Examples
    --------
    >>> T = arc_views(3, 10.0, TARGET_BASE, rng=0)
    >>> bool(np.allclose(reported_poses(T, rng=0), T))
    True
    """
    rng = np.random.default_rng(rng)
    reported = np.stack([perturb_pose(T, pose_error[0], pose_error[1], rng) for T in np.asarray(T_base_optical, dtype=float)])
    if any(hand_eye_error):
        reported = reported @ hand_eye_offset(hand_eye_error[0], hand_eye_error[1], rng)
    return reported
