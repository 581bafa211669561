"""How large a pose error the view-shift warning sees (``methods/bayes/view_shift.py``), and how often it cries wolf.

The paper's scene (6 fruit, its 3 views, 640 x 480) with the paper's box noise (5 %, 2 % missed boxes): one view's
reported pose turned by ANGLE degrees about a random axis in its image plane (its boxes all move by about f ANGLE),
the others exact. Per angle, over the seeds: the share of sessions in which the turned view is reported, and in
which another one is (with three views, a turned view also pulls the objects, so the others can look shifted the
other way; at 0 degrees every report is a false alarm).

``--alarms``: the accuracy benchmark's noisy conditions without pose error (:func:`monovisual3d.bench.accuracy.conditions`,
its scenes, noise and options), every report a false alarm: views reported of views run, per condition.

Usage::

    python experiments/view_shift.py [FIRST LAST]            # seeds FIRST..LAST-1, default 0 40
    python experiments/view_shift.py --alarms [FIRST LAST]   # default 0 20
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

import monovisual3d as mv
from monovisual3d.bench.accuracy import conditions, simulated_session
from monovisual3d.session import Session, View
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.simulate import simulate

ANGLES_DEG = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0)
#: The accuracy benchmark's conditions of ``alarms``: box noise, leaves, false positives, shapes; exact poses.
ALARM_CONDITIONS = ("paper-noise", "greenhouse", "greenhouse-noise", "greenhouse-clutter", "shapes-noise", "shapes-occluded")
#: The view whose pose is turned.
TURNED = 1


def turned_session(seed: int, angle_deg: float) -> Session:
    """The paper scene's noisy session, view :data:`TURNED`'s pose turned by ``angle_deg`` about a random axis in
    its image plane (drawn from the seed)."""
    session, _ = simulate(paper_scene(), noise=NoiseModel.paper(), rng=seed)
    phi = np.random.default_rng(10_000 + seed).uniform(0.0, 2 * np.pi)
    views = list(session.views)
    T = views[TURNED].T_base_optical.copy()
    axis = np.array([np.cos(phi), np.sin(phi), 0.0])
    T[:3, :3] = T[:3, :3] @ Rotation.from_rotvec(np.radians(angle_deg) * axis).as_matrix()
    views[TURNED] = View(T, views[TURNED].detections)
    return Session(session.camera, tuple(views), session.workspace)


def main(seeds: range) -> None:
    print(f"paper scene, 5 % box noise, view {TURNED} turned; seeds {seeds.start}-{seeds.stop - 1}")
    print("| turn (degrees) | turned view reported | another view reported |")
    print("|---:|---:|---:|")
    for angle in ANGLES_DEG:
        hit = other = 0
        for seed in seeds:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = mv.localize(turned_session(seed, angle))
            reported = {s["view"] for s in result.diagnostics["view_shifts"]}
            hit += TURNED in reported
            other += bool(reported - {TURNED})
        print(f"| {angle:g} | {hit} of {len(seeds)} | {other} of {len(seeds)} |")


def false_alarms(seeds: range) -> None:
    """Views reported of views run, per condition of :data:`ALARM_CONDITIONS` (every report a false alarm)."""
    print(f"the accuracy benchmark's conditions with exact poses; seeds {seeds.start}-{seeds.stop - 1}")
    print("| condition | views reported | views |")
    print("|---|---:|---:|")
    for cond in (c for c in conditions() if c.name in ALARM_CONDITIONS):
        reported = views = 0
        for seed in seeds:
            session, _ = simulated_session(cond.scene(seed), cond.noise, seed, masks=cond.masks)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = mv.localize(session, **cond.method_options("bayes"))
            reported += len(result.diagnostics["view_shifts"])
            views += len(session.views)
        print(f"| {cond.name} | {reported} | {views} |")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first", nargs="?", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("last", nargs="?", type=int, default=None, help="last seed, excluded (default 40; 20 with --alarms)")
    parser.add_argument("--alarms", action="store_true", help="false alarms on the accuracy benchmark's conditions instead")
    args = parser.parse_intermixed_args()
    last = args.last if args.last is not None else (20 if args.alarms else 40)
    if not 0 <= args.first < last:
        parser.error(f"expected seeds with 0 <= FIRST < LAST, got {args.first} {last}")
    (false_alarms if args.alarms else main)(range(args.first, last))
