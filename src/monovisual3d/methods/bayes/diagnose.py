"""The ``diagnose`` pass: name a mistake every view shares from the pattern it leaves in the boxes' residuals.

The objects found are refitted as spheres, all at once, alone and then jointly with each correction model of
:mod:`.corrections` (a hand-eye error, a time offset between poses and images, another image size or a crop, a
residual lens pattern). A model names a cause (:class:`~monovisual3d.verdict.Cause`) when both hold:

- its chi-square drop is significant: beyond the chi-square quantile of :data:`FALSE_ALARM_P` for its degrees of
  freedom (the residuals in units of the noise the spheres alone leave, so a noisier detector does not fire it);
- the correction is large enough to matter physically (:func:`matters`): a hand-eye error or the pose change of a
  time offset of :data:`MIN_ROTATION_DEG` or :data:`MIN_TRANSLATION_M` and more, an image scale off by
  :data:`MIN_SCALE` or an offset of :data:`MIN_SHIFT_PX`, a lens pattern that moves the image corners by
  :data:`MIN_SHIFT_PX` (less changes the fruit by less than their noise).

The model named is the one with the largest drop less twice its degrees of freedom (Akaike's penalty). Where
another model removes at least :data:`RIVAL_SHARE` of the best one's drop, the two explain the same pattern
(a small camera rotation moves every box as a principal-point offset does): the message names both. Runs only where
the data can tell: :data:`MIN_VIEWS` views or more and :data:`MIN_OBJECTS` objects seen in three views or more;
the refit is capped at :data:`.correction_boxes.MAX_OBJECTS` objects (the best seen), so its cost stays bounded.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from ...verdict import Cause
from .correction_boxes import Boxes, boxes_of
from .corrections import (
    MODELS,
    Comparison,
    Fit,
    compare_corrections,
    distortion_shift,
    fit_correction,
    hand_eye_summary,
    view_velocities,
)
from .problem import Problem
from .state import Found, State

#: Views the correction tests need (a hand-eye error has 6 parameters; three views leave it nearly free).
MIN_VIEWS = 4
#: Objects seen in three views or more the tests need.
MIN_OBJECTS = 3
#: The chance that a correct session's chi-square drop passes a model's test (per model), under the noise model
#: (why: docs/decisions/bayes-corrections.md#false_alarm_p).
FALSE_ALARM_P = 1e-3
#: The smallest camera rotation and translation named (a hand-eye error, a time offset's pose change): less moves a
#: fruit half a metre away by less than about 4 mm, within the noise of a few views
#: (why: docs/decisions/bayes-corrections.md#min_rotation_deg).
MIN_ROTATION_DEG, MIN_TRANSLATION_M = 0.5, 0.005
#: The smallest image scale error (relative) and pixel offset or lens pattern (pixels, at the image corners) named.
MIN_SCALE, MIN_SHIFT_PX = 0.01, 3.0
#: A view is named as disagreeing when at least this share of its boxes, and :data:`MIN_BAD_BOXES` or more, fit no
#: object the other views agree on (held by none, or off on two edges or more by :data:`OUTLIER_SIGMAS`), and no other
#: view comes within half of its share (why: docs/decisions/bayes-corrections.md#bad_view_share).
BAD_VIEW_SHARE, MIN_BAD_BOXES = 0.5, 3
#: An edge this many noise sigmas (the noise the spheres leave) off its prediction is an outlier.
OUTLIER_SIGMAS = 3.0
#: A model that removes this share of the best model's drop explains the same pattern: named as its rival
#: (why: docs/decisions/bayes-corrections.md#rival_share).
RIVAL_SHARE = 0.8


def can_tell(b: Boxes | None) -> bool:
    """Whether the correction tests can tell anything: enough views, and objects seen in three or more."""
    return b is not None and b.n_views >= MIN_VIEWS and int(np.sum(b.views_per_object() >= 3)) >= MIN_OBJECTS


def models_for(b: Boxes) -> list[str]:
    """The models worth testing on ``b``: a time offset only where the views have distinct stamps or positions
    along a path (always here: the view order stands in), every other model always."""
    return list(MODELS)


def effect_px(b: Boxes, base: Fit, test: Comparison) -> float:
    """RMS move (pixels) of the predicted box edges from the spheres alone to the spheres with the correction, each at
    its own optimum: the pattern the correction explains (what the spheres take up of it, e.g. a move of the whole
    scene, does not count)."""
    return float(np.sqrt(np.mean(edge_moves(b, base, test.fit) ** 2)))


def edge_moves(b: Boxes, base: Fit, fit: Fit) -> np.ndarray:
    """The predicted box edges' moves (pixels, finite ones) from the fit ``base`` to ``fit``."""
    from .corrections import predicted_boxes

    d = predicted_boxes(b, fit) - predicted_boxes(b, base)
    return d[np.isfinite(d)]


def magnitude(b: Boxes, test: Comparison) -> dict[str, float]:
    """The correction's size in physical units: ``rotation_deg`` and ``translation_mm`` (hand-eye; the largest pose
    change over the views for a time offset), ``scale`` (relative) and ``shift_px`` (image geometry), ``corner_px``
    (the lens pattern's largest move of an image corner)."""
    th = test.fit.theta
    if test.model == "hand_eye":
        return {
            "rotation_deg": math.degrees(float(np.linalg.norm(th[:3]))),
            "translation_mm": 1e3 * float(np.linalg.norm(th[3:6])),
        }
    if test.model == "time_offset":
        vel = view_velocities(b.T_optical_base, b.stamps)
        return {
            "rotation_deg": math.degrees(abs(th[0]) * float(np.max(np.linalg.norm(vel[:, :3], axis=1)))),
            "translation_mm": 1e3 * abs(th[0]) * float(np.max(np.linalg.norm(vel[:, 3:], axis=1))),
        }
    if test.model == "image_geometry":
        return {"scale": float(np.max(np.abs(np.expm1(th[:2])))), "shift_px": float(np.hypot(th[2], th[3]))}
    cam = b.camera
    x = (np.array([[0.0, cam.width, 0.0, cam.width]]) - cam.cx) / cam.fx
    y = (np.array([[0.0, 0.0, cam.height, cam.height]]) - cam.cy) / cam.fy
    du, dv = distortion_shift(cam, x, y, th[None])
    return {"corner_px": float(np.max(np.hypot(du, dv)))}


def matters(size: dict[str, float]) -> bool:
    """Whether a correction of :func:`magnitude` ``size`` is large enough to name (see the module docstring)."""
    return (
        size.get("rotation_deg", 0.0) >= MIN_ROTATION_DEG
        or size.get("translation_mm", 0.0) >= 1e3 * MIN_TRANSLATION_M
        or size.get("scale", 0.0) >= MIN_SCALE
        or size.get("shift_px", 0.0) >= MIN_SHIFT_PX
        or size.get("corner_px", 0.0) >= MIN_SHIFT_PX
    )


def significant(test: Comparison) -> bool:
    """Whether the drop is beyond what noise gives with probability :data:`FALSE_ALARM_P`."""
    from scipy.special import chdtri  # chi2.isf(p, dof); on first use, as scipy.stats costs 0.4 s to import

    return test.chi2_drop > float(chdtri(test.dof, FALSE_ALARM_P))


def _what(test: Comparison, b: Boxes) -> str:
    """The correction in words and numbers (one clause)."""
    th = test.fit.theta
    if test.model == "hand_eye":
        s = hand_eye_summary(test.fit)
        return f"a hand-eye (camera-frame) error of {s['rotation_deg']:.1f} degrees and {s['translation_mm']:.0f} mm"
    if test.model == "time_offset":
        unit = "s" if b.stamps[-1] - b.stamps[0] != b.n_views - 1 or b.stamps[0] != 0 else "frames"
        return f"a time offset of {th[0]:+.3g} {unit} between the poses and the images"
    if test.model == "image_geometry":
        return (
            f"another image size or a crop (boxes scaled {math.exp(th[0]):.3f} x {math.exp(th[1]):.3f} and offset "
            f"{th[2]:+.0f}, {th[3]:+.0f} px from the calibration's image)"
        )
    return f"a lens distortion pattern off the calibration's (k1 {th[0]:+.3f}, p1 {th[1]:+.4f}, p2 {th[2]:+.4f})"


#: What to check, per model.
ADVICE = {
    "hand_eye": "check the hand-eye calibration (T_ee_camera) or estimate it with --calibrate hand-eye",
    "time_offset": "check the time offset between the pose stream and the image stamps, or import with --time-offset auto",
    "image_geometry": "check that the image size (resolution, crop or resize) the detector saw is the calibration's "
    "(import --image-size, --crop)",
    "radial_distortion": "check the distortion coefficients' order (k1, k2, p1, p2, k3) and signs",
}
#: What to check, per model, in a rival's few words.
RIVAL_CHECK = {
    "hand_eye": "check the hand-eye calibration",
    "time_offset": "check the poses' time stamps",
    "image_geometry": "check the image size the detector saw",
    "radial_distortion": "check the distortion coefficients",
}
#: The cause ID each model names.
CAUSE_OF = {
    "hand_eye": "hand_eye",
    "time_offset": "time_offset",
    "image_geometry": "image_size",
    "radial_distortion": "distortion",
}


def bad_boxes(problem: Problem, objects: list[Found], b: Boxes | None, base: Fit | None) -> dict[int, tuple[int, int]]:
    """Per view (session index): how many of its boxes fit no object the other views agree on (held by none, or, in
    the spheres' fit ``base`` of ``b``, off by :data:`OUTLIER_SIGMAS` on two edges or more), and its number of boxes."""
    held = {(v, j) for o in objects for v, j in o.associations.items()}
    off: dict[int, int] = {}
    if b is not None and base is not None:
        from .corrections import _Residuals, _x0, scaled_sigma

        e = _Residuals(b, None, scaled_sigma(b, base))(_x0(b, base)[None])[0].reshape(-1, 4)
        outlier = np.sum(np.abs(e) > OUTLIER_SIGMAS, axis=1) >= 2
        for row in np.flatnonzero(outlier):
            v = b.session_views[int(b.view[row])]
            off[v] = off.get(v, 0) + 1
    out = {}
    for vd in problem.views:
        free = sum((vd.index, j) not in held for j in range(len(vd.boxes)))
        out[vd.index] = (free + off.get(vd.index, 0), len(vd.boxes))
    return out


def disagreeing_views(counts: dict[int, tuple[int, int]]) -> list[Cause]:
    """The ``view_disagrees`` causes of :func:`bad_boxes`' counts (see :data:`BAD_VIEW_SHARE`): one view, or two (a
    swap) where both stand out."""
    share = {v: bad / n for v, (bad, n) in counts.items() if n}
    if len(share) < 3:
        return []
    ranked = sorted(share, key=lambda v: -share[v])
    named = [v for v in ranked[:2] if share[v] >= BAD_VIEW_SHARE and counts[v][0] >= MIN_BAD_BOXES]
    rest = [share[v] for v in ranked if v not in named]
    if not named or (rest and max(rest) > 0.5 * min(share[v] for v in named)):
        return []
    return [
        Cause(
            "view_disagrees",
            f"views[{v}]: {counts[v][0]} of its {counts[v][1]} boxes fit no object the other views agree on: this view's "
            "boxes may be another image's, or its pose another view's or wrong (check its image, detections and pose)",
            "suspect",
            (v,),
            {"bad_boxes": counts[v][0], "boxes": counts[v][1]},
        )
        for v in named
    ]


def diagnose(problem: Problem, objects: list[Found]) -> tuple[list[Cause], dict[str, Any]]:
    """The causes the correction tests name (at most one, its rivals in its message) and the tests' numbers
    (``corrections``: per model its ``chi2_drop``, ``dof``, ``effect_px``, ``significant``; empty where the data
    cannot tell)."""
    b = boxes_of(problem, objects)
    if not can_tell(b):
        if b is None or len(problem.views) < 3:
            return [], {}
        from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

        with threadpool_limits(limits=1):
            base = fit_correction(b, None)
        return disagreeing_views(bad_boxes(problem, objects, b, base)), {}
    assert b is not None
    from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

    # one BLAS thread: the fits' matrices are a few dozen wide, and a BLAS pool on a busy machine made them 5x slower
    with threadpool_limits(limits=1):
        base, tests = compare_corrections(b, models_for(b))
    numbers: dict[str, Any] = {"noise_scale": base.noise_scale, "chi2": base.chi2, "n_residuals": base.n_residuals}
    fired = []
    for t in tests:
        size = magnitude(b, t)
        sig = significant(t)
        numbers[t.model] = {
            "chi2_drop": t.chi2_drop,
            "dof": t.dof,
            "effect_px": effect_px(b, base, t),
            "significant": sig,
            **size,
        }
        if sig and matters(size):
            fired.append(t)
    views = disagreeing_views(bad_boxes(problem, objects, b, base))
    if not fired:
        return views, {"corrections": numbers}
    best = max(fired, key=lambda t: t.chi2_drop - 2 * t.dof)
    rivals = [t for t in fired if t is not best and t.chi2_drop >= RIVAL_SHARE * best.chi2_drop]
    msg = (
        f"the boxes of all {b.n_views} views are off in one pattern that {_what(best, b)} explains (chi-square drop "
        f"{best.chi2_drop:.0f} on {best.dof} degrees of freedom): {ADVICE[best.model]}"
    )
    if rivals:
        msg += "; as well explained by " + " or ".join(f"{_what(r, b)} ({RIVAL_CHECK[r.model]})" for r in rivals)
    details = {
        "model": best.model,
        "theta": [float(x) for x in best.fit.theta],
        "chi2_drop": best.chi2_drop,
        "dof": best.dof,
        "rivals": [r.model for r in rivals],
    }
    if best.model == "hand_eye":
        details["hand_eye"] = {k: v for k, v in hand_eye_summary(best.fit).items() if k != "T_corrected_reported"}
    return [Cause(CAUSE_OF[best.model], msg, "suspect", (), details), *views], {"corrections": numbers}


def run(problem: Problem, state: State) -> State:
    """The pass: the causes the correction tests name, added to the state's."""
    causes, _ = diagnose(problem, list(state.objects))
    return replace(state, causes=state.causes + tuple(causes)) if causes else state
