"""The frozen data every stage of the ``bayes`` pipeline reads.

A :class:`Problem` is the camera, the options and the views with detections,
fixed for one :func:`~monovisual3d.methods.bayes.pipeline.estimate` call. Which
boxes are already explained by an accepted object is passed explicitly as a
``taken`` set of ``(v, j)`` pairs (``v``: position in ``Problem.views``,
``j``: detection index in that view), never as flags shared between stages.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ...camera import Camera
from ...errors import InputError
from ...frames import invert_transform
from ...grid import VoxelGrid
from ...masks import contour_points
from ...session import View
from .config import BayesConfig
from .sensor import SensorModel


@dataclass(frozen=True)
class ViewData:
    """One view with detections, as the pipeline reads it.

    Attributes
    ----------
    index : int, the view's index in the session
    T_optical_base : ndarray, shape (4, 4), base frame -> optical frame
    boxes : ndarray, shape (B, 4), float64, bbox_xyxy, pixels
    contours : tuple of (ndarray, shape (M, 2), pixels) or None, one per box: the mask outline when used
    view : View, the session's view
    """

    index: int
    T_optical_base: NDArray[np.float64]
    boxes: NDArray[np.float64]
    contours: tuple[NDArray[np.float64] | None, ...]
    view: View


@dataclass(frozen=True)
class Problem:
    """Camera, options, sensor model, the views with detections of one estimate, and the region searched
    (:class:`~monovisual3d.grid.VoxelGrid`, only a description: None before a view has detections)."""

    camera: Camera
    config: BayesConfig
    model: SensorModel
    views: tuple[ViewData, ...]
    region: VoxelGrid | None = None
    #: The last ``taken`` set of :meth:`available` and its answer (an extraction asks hundreds of times between takes).
    _last_available: dict[frozenset[tuple[int, int]], list[NDArray[np.bool_]]] = field(
        default_factory=dict, init=False, compare=False, repr=False
    )
    #: The views by their index in the session (:meth:`view_at`), built on first use.
    _by_index: dict[int, ViewData] = field(default_factory=dict, init=False, compare=False, repr=False)

    def available(self, taken: Iterable[tuple[int, int]] = ()) -> list[NDArray[np.bool_]]:
        """Per view, which boxes are not in ``taken``: list of ndarray, shape (B_v,), bool, read-only."""
        key = taken if isinstance(taken, frozenset) else frozenset((int(v), int(j)) for v, j in taken)
        cached = self._last_available.get(key)
        if cached is None:
            cached = [np.ones(len(vd.boxes), dtype=bool) for vd in self.views]
            for v, j in key:
                cached[v][j] = False
            for a in cached:
                a.flags.writeable = False
            self._last_available.clear()
            self._last_available[key] = cached
        return list(cached)  # a new list of the shared read-only arrays

    def view_at(self, index: int) -> ViewData:
        """The view whose index in the session is ``index`` (an object's ``associations`` are keyed so)."""
        if not self._by_index:
            self._by_index.update((vd.index, vd) for vd in self.views)
        try:
            return self._by_index[index]
        except KeyError:
            raise KeyError(f"no view with session index {index} has detections here ({sorted(self._by_index)})") from None

    def depth(self, v: int, p_base: NDArray[np.floating]) -> float:
        """Depth (optical z, metres) of the point ``p_base`` (shape (3,), base frame) in view ``v``."""
        T = self.views[v].T_optical_base
        return float(T[2, :3] @ p_base + T[2, 3])


def build_problem(camera: Camera, config: BayesConfig, views: Sequence[View], region: VoxelGrid | None = None) -> Problem:
    """The :class:`Problem` of ``views`` searched over ``region`` (views without detections are left out; masks decoded
    once)."""
    data = []
    for i, v in enumerate(views):
        if not v.detections:
            continue
        contours: list[NDArray[np.float64] | None] = []
        for j, d in enumerate(v.detections):
            if config.use_masks and d.mask is not None:
                try:
                    contours.append(contour_points(d.mask))
                except InputError as exc:
                    raise InputError(f"views[{i}].detections[{j}].{exc}") from None
            else:
                contours.append(None)
        data.append(ViewData(i, invert_transform(v.T_base_optical), v.boxes_xyxy, tuple(contours), v))
    return Problem(camera, config, config.sensor, tuple(data), region)
