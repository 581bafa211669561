"""The boxes the correction fits of :mod:`.corrections` read: the found objects' boxes in their views, with the
views' reported poses and stamps (:func:`boxes_of`), or a simulated scene's (:func:`synthetic_boxes`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from .problem import Problem
from .sensor import SensorModel, censored_edges

#: Objects refitted at most by default (those seen in the most views first): bounds the cost on large scenes. Twelve
#: fruit in four views or more give some 200 edges for at most 6 correction parameters; 20 cost twice as much (0.085
#: against 0.037 s CPU on a 48-fruit row), for a pass whose budget is the 10 % that issue 53 allows.
MAX_OBJECTS = 12


@dataclass(frozen=True)
class Boxes:
    """The boxes of the objects refitted, as the correction fits read them.

    Attributes
    ----------
    camera : Camera
    model : SensorModel
    T_optical_base : ndarray, shape (V, 4, 4), the views' reported poses (base -> optical)
    stamps : ndarray, shape (V,), seconds (or view positions where the session has no stamps), increasing
    obj : ndarray, shape (P,), int, the object of each box
    view : ndarray, shape (P,), int, the view (row of ``T_optical_base``) of each box
    xyxy : ndarray, shape (P, 4), pixels, ``bbox_xyxy``
    centres : ndarray, shape (N, 3), metres, base frame, the objects' starting centres
    radii : ndarray, shape (N,), metres, their starting radii
    session_views : tuple of int, the session index of each view
    """

    camera: Camera
    model: SensorModel
    T_optical_base: NDArray[np.float64]
    stamps: NDArray[np.float64]
    obj: NDArray[np.int_]
    view: NDArray[np.int_]
    xyxy: NDArray[np.float64]
    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    session_views: tuple[int, ...] = ()
    censored: NDArray[np.bool_] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        cam = self.camera
        object.__setattr__(self, "censored", censored_edges(self.xyxy, cam.width, cam.height, self.model.border_px))

    @property
    def n_objects(self) -> int:
        return len(self.centres)

    @property
    def n_views(self) -> int:
        return len(self.T_optical_base)

    def views_per_object(self) -> NDArray[np.int_]:
        """How many views each object has a box in, shape (N,)."""
        return np.bincount(self.obj, minlength=self.n_objects)

    def p_optical(self, centres: NDArray[np.float64]) -> NDArray[np.float64]:
        """The centres (B, N, 3), base frame, in each box's reported optical frame: shape (B, P, 3)."""
        T = self.T_optical_base[self.view]
        c = centres[:, self.obj]
        return np.einsum("pij,bpj->bpi", T[:, :3, :3], c) + T[:, :3, 3]


def boxes_of(problem: Problem, objects: Sequence[Any], max_objects: int = MAX_OBJECTS) -> Boxes | None:
    """The boxes of the objects (each with ``position``, ``radius``, ``associations``: a found object or a result's)
    seen in two views or more (at most ``max_objects``, most views first), as :class:`Boxes`; None without any. The
    views' stamps where every view has one and they increase, else their positions in the session order."""
    seen = sorted((o for o in objects if len(o.associations) >= 2 and o.radius), key=lambda o: -len(o.associations))
    seen = seen[:max_objects]
    if not seen:
        return None
    views = sorted({v for o in seen for v in o.associations})
    row = {v: k for k, v in enumerate(views)}
    obj, view, xyxy = [], [], []
    for i, o in enumerate(seen):
        for v, j in sorted(o.associations.items()):
            obj.append(i)
            view.append(row[v])
            xyxy.append(problem.view_at(v).boxes[j])
    stamps = [problem.view_at(v).view.stamp for v in views]
    t = np.array(stamps, dtype=float) if all(s is not None for s in stamps) else np.arange(len(views), dtype=float)
    if len(t) > 1 and not np.all(np.diff(t) > 0):
        t = np.arange(len(views), dtype=float)
    return Boxes(
        problem.camera,
        problem.model,
        np.stack([problem.view_at(v).T_optical_base for v in views]),
        t,
        np.array(obj),
        np.array(view),
        np.array(xyxy, dtype=float),
        np.stack([o.position for o in seen]),
        np.array([float(o.radius) for o in seen]),  # type: ignore[arg-type]
        tuple(views),
    )


def synthetic_boxes(
    camera: Camera,
    poses: NDArray[np.float64],
    centres: NDArray[np.float64],
    radii: NDArray[np.float64],
    *,
    E: NDArray[np.float64] | None = None,
    box_sigma: float = 0.0,
    rng: np.random.Generator | int | None = None,
    model: SensorModel | None = None,
) -> Boxes:
    """The boxes of spheres (``centres`` (N, 3), base frame, ``radii`` (N,), metres) seen from ``poses``
    (``T_base_optical`` (V, 4, 4)), exact or with relative noise ``box_sigma``, under poses reported with a camera-frame
    error ``E`` (4, 4; None: exact; reported ``T_base_optical @ E``); the spheres start at the truth. For tests and
    studies.

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> cam = Camera.from_hfov(640, 480, 69.0)
    >>> poses = np.stack([look_at([0.0, y, 0.0], [0.6, 0.0, 0.0]) for y in (-0.2, 0.0, 0.2)])
    >>> synthetic_boxes(cam, poses, np.array([[0.6, 0.0, 0.0]]), np.array([0.03])).xyxy.shape
    (3, 4)
    """
    from ...frames import invert_transform
    from ...geometry.sphere import sphere_bbox

    rng = np.random.default_rng(rng)
    centres, radii = np.asarray(centres, dtype=float), np.asarray(radii, dtype=float)
    obj, view, xyxy = [], [], []
    for v, T in enumerate(poses):
        for i, box in enumerate(sphere_bbox(camera, T, centres, radii)):
            if np.all(np.isfinite(box)):
                size = np.array([box[2] - box[0], box[3] - box[1]] * 2)
                obj.append(i)
                view.append(v)
                xyxy.append(box + box_sigma * size * rng.normal(size=4))
    reported = poses if E is None else poses @ E
    return Boxes(
        camera,
        model or SensorModel(),
        np.stack([invert_transform(T) for T in reported]),
        np.arange(len(poses), dtype=float),
        np.array(obj),
        np.array(view),
        np.array(xyxy),
        centres,
        radii,
        tuple(range(len(poses))),
    )
