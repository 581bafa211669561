"""The per-view assignment (:mod:`monovisual3d.methods.bayes.view_assign`): a chain of trades in one view undone."""

from __future__ import annotations

import warnings

import numpy as np

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.orientation import rotation_upright
from monovisual3d.geometry.solids import cuboid_bbox
from monovisual3d.session import Detection, Session, View, Workspace

CAMERA = Camera.from_hfov(1280, 720, 69.0)
MIDDLE = np.array([0.6084, 0.0066, 0.3059])
#: Two squat cuboid containers (6 x 6 x 8 cm, 7 cm apart, yawed) before a flat tray 7 cm behind and 4.5 cm lower.
CENTRES = np.array([MIDDLE - [0.0, 0.035, 0.0], MIDDLE + [0.0, 0.035, 0.0], MIDDLE + [0.07, 0.0, -0.045]])
HALF_SIDES = np.array([[0.03, 0.03, 0.04], [0.03, 0.03, 0.04], [0.10, 0.08, 0.015]])
YAWS = (0.3079, 1.4586, 1.7339)
#: Three views 20 degrees above: two from one side, the third from the side where the nearer container's box lies
#: inside the tray's (camera position, aim point; metres, base frame).
VIEWS = (
    ([0.3783, -0.4710, 0.4988], [0.6049, 0.0063, 0.3010]),
    ([0.2400, -0.2871, 0.4773], [0.6127, 0.0092, 0.3204]),
    ([0.3267, 0.5914, 0.5421], [0.5957, 0.0038, 0.2981]),
)


def _errors_mm(result: mv.Result) -> np.ndarray:
    """Per true object, the distance (mm) to the nearest estimate."""
    return np.array([1e3 * min(np.linalg.norm(o.position - c) for o in result.objects) for c in CENTRES])


def _session() -> Session:
    views = []
    for position, aim in VIEWS:
        T = look_at(position, aim)
        boxes = [cuboid_bbox(CAMERA, T, c, s, rotation_upright(y)) for c, s, y in zip(CENTRES, HALF_SIDES, YAWS)]
        views.append(View(T, tuple(Detection(b) for b in boxes)))
    return Session(CAMERA, tuple(views), Workspace(MIDDLE - 0.2, MIDDLE + 0.2))


def _localize(**options: object) -> mv.Result:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return mv.localize(_session(), size_range=[0.02, 0.15], reach=1.0, **options)


def test_a_chain_of_trades_in_one_view_is_undone() -> None:
    """Exact boxes: every object within 3 mm, each holding its own box in every view; without the pass container A
    holds B's box in the third view, B the tray's, and no estimate lies within 30 mm of either container or the tray."""
    result = _localize()
    assert np.all(_errors_mm(result) < 3.0), _errors_mm(result)
    for o in result.objects:
        (k,) = set(o.associations.values())  # one object's boxes: the same index in every view
        assert np.linalg.norm(o.position - CENTRES[k]) < 3e-3
    without = _errors_mm(_localize(view_assign=False))
    assert np.all(without > 30.0), without
