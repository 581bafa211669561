"""The steal pass (:mod:`monovisual3d.methods.bayes.steal`)."""

from __future__ import annotations

import numpy as np

import monovisual3d as mv
from monovisual3d.camera import Camera
from monovisual3d.frames import look_at
from monovisual3d.geometry.sphere import sphere_bbox
from monovisual3d.methods.bayes import BayesConfig
from monovisual3d.methods.bayes.problem import build_problem
from monovisual3d.methods.bayes.state import Found
from monovisual3d.methods.bayes.steal import _replacement
from monovisual3d.session import Detection, Session, View

CAM = Camera.from_hfov(640, 480, 69.0)
TARGET = np.array([0.7, 0.0, 0.5])


def _two_fruit():
    centres = np.array([TARGET, TARGET + [0.0, 0.15, 0.0]])
    poses = [look_at(TARGET + step, TARGET) for step in ([-0.5, 0.0, 0.0], [-0.45, 0.2, 0.05], [-0.45, -0.2, -0.05])]
    views = tuple(View(T, tuple(Detection(b) for b in sphere_bbox(CAM, T, centres, np.array([0.03, 0.03])))) for T in poses)
    session = Session(CAM, views)
    return session, mv.localize(session, use_masks=False)


def test_replacement_is_the_free_box_that_fits_the_holder_within_the_gate():
    session, res = _two_fruit()
    problem = build_problem(CAM, BayesConfig(), session.views)
    r = min(res.objects, key=lambda o: np.linalg.norm(o.position - TARGET))
    o = Found(r.position, r.score, r.radius, r.covariance, r.associations)  # a sphere, as the pass sees it
    for v in range(3):
        own, other = o.associations[v], 1 - o.associations[v]
        free = np.ones(2, dtype=bool)
        assert _replacement(problem, o, v, free, set()) == own
        # the other fruit's box lies 15 cm away, far outside the gate; a box given away or held is not offered
        assert _replacement(problem, o, v, free, {(v, own)}) == -1
        assert _replacement(problem, o, v, np.array([own == 1, own == 0]), set()) == -1
        assert _replacement(problem, o, v, np.array([own == 0, own == 1]), {(v, other)}) == own


def test_steal_pass_gives_the_holder_its_own_free_box_in_exchange():
    """Greenhouse-noise seed 8018 (leaves cut both fruit): the extraction gives fruit 7 the view-2 box of fruit 5, whose
    own boxes in views 0 and 1 are left to a 2-view object below ``accept`` (fruit 5 is missed), while fruit 7's own
    view-2 box stays free. Taking fruit 5's box back costs fruit 7 a whole view unless it takes its own free box
    there instead; with that exchange both come out with their own boxes (before it: fruit 5 missed, fruit 7 35 mm
    off with fruit 5's box)."""
    from monovisual3d.bench.accuracy import conditions, simulated_session

    cond = next(c for c in conditions() if c.name == "greenhouse-noise")
    scene = cond.scene(8018)
    session, svs = simulated_session(scene, cond.noise, 8018, masks=False)
    res = mv.localize(session, **cond.method_options("bayes"))
    for f in (5, 7):
        own = {v: int(np.flatnonzero(sv.source == f)[0]) for v, sv in enumerate(svs) if f in sv.source}
        d = np.linalg.norm(res.positions - scene.centres[f], axis=1)
        assert d.min() < scene.radii[f]
        assert res.objects[int(np.argmin(d))].associations == own
    off = mv.localize(session, **{**cond.method_options("bayes"), "steal": False})
    assert np.linalg.norm(off.positions - scene.centres[5], axis=1).min() > scene.radii[5]
