"""``calibrate="hand-eye"``: one camera-frame correction shared by every view, estimated with the fruit and applied.

A hand-eye calibration off by a degree or a centimetre puts the same error ``E`` (4, 4, optical frame) in every view:
the reported pose is ``T_base_optical_true @ E``. After the method's estimate, the objects are refitted as spheres,
all at once, jointly with ``E`` (:func:`.corrections.fit_correction`, model ``hand_eye``); the views' poses are then
corrected (``T_base_optical_reported @ E^-1``) and the method runs again on them, so that every object is estimated
anew (association, shape and covariance) from corrected poses. A second round estimates what is left of ``E`` from the
new objects, and applies it too where it is not negligible (:data:`NEGLIGIBLE_DEG`, :data:`NEGLIGIBLE_M`).

It needs :data:`MIN_VIEWS` views and :data:`MIN_FRUIT` fruit seen in two views or more, a correction the views
determine (its angle and length known within :data:`UNRELIABLE_DEG`, :data:`UNRELIABLE_M`) and one that differs from
none beyond the noise (:data:`NO_ERROR_P`); otherwise the method runs as usual and says why. What the views cannot
tell apart from a motion of the whole scene (on an arc of views about one axis: a rotation about that axis with a
sideways shift) stays at zero, held by the fit's weak prior; the reported uncertainty (from the covariance of the
joint fit) says how well each part is known.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ...frames import invert_transform
from .correction_boxes import boxes_of
from .corrections import fit_correction, hand_eye_summary
from .problem import Problem, build_problem

#: The method's output (:class:`.pipeline.Estimate`; not imported: the pipeline sits above this helper).
Estimate = Any

#: Views and fruit (seen in two views or more) a hand-eye correction needs.
MIN_VIEWS, MIN_FRUIT = 5, 6
#: Objects refitted at most (those seen in the most views first).
MAX_OBJECTS = 40
#: A second round's correction below both of these is not applied (it moves a fruit by well under a millimetre).
NEGLIGIBLE_DEG, NEGLIGIBLE_M = 0.02, 0.0003
#: A part of the correction whose 1-sigma exceeds these is reported as not determined by the views.
UNDETERMINED_DEG, UNDETERMINED_M = 0.5, 0.005
#: A correction with a part whose 1-sigma exceeds these is not applied: so poorly determined, it may move the fruit
#: further from the truth than the error it corrects (views from directions too alike: a turn of the camera and a
#: sideways shift then look the same; why: docs/decisions/bayes-corrections.md#unreliable_deg).
UNRELIABLE_DEG, UNRELIABLE_M = 0.75, 0.0075
#: A first correction is applied only where it differs from none beyond the noise: its six parameters' squared
#: Mahalanobis distance from zero (under the joint fit's covariance) above the chi-square quantile of this upper tail.
#: On correct poses the fit still finds a small correction from the noise (0.27-0.41 degrees from 10 views at 2 % box
#: noise), which applied makes the fruit 1.5-3 times as far off (why: docs/decisions/bayes-corrections.md#no_error_p).
NO_ERROR_P = 1e-3


def corrected_problem(problem: Problem, T_corrected_reported: np.ndarray) -> Problem:
    """``problem`` with every view's pose corrected: ``T_optical_base = T_corrected_reported @ T_optical_base``."""
    views = [replace(vd.view, T_base_optical=invert_transform(T_corrected_reported @ vd.T_optical_base)) for vd in problem.views]
    # views without detections are not in the problem; the corrected views keep their session indices
    out = build_problem(problem.camera, problem.config, views, problem.region)
    return replace(out, views=tuple(replace(vd, index=old.index) for vd, old in zip(out.views, problem.views)))


def calibrate_hand_eye(problem: Problem, first: Estimate, estimate: Callable[[Problem], Estimate]) -> Estimate:
    """The estimate with a hand-eye correction estimated and applied (see the module docstring); the report is in
    its ``diagnostics["calibration"]``: ``applied`` (bool), ``reason`` (where not applied), and the correction
    (:func:`.corrections.hand_eye_summary`: ``rotation_deg``, ``axis_optical``, ``translation_mm``, ... with their
    1-sigma) with ``undetermined`` (the parts the views leave free). ``estimate`` is the method
    (:func:`.pipeline.estimate`), run again on the corrected poses."""
    b = boxes_of(problem, first.objects, MAX_OBJECTS)  # type: ignore[arg-type]
    n_views = 0 if b is None else b.n_views
    n_fruit = 0 if b is None else b.n_objects
    if n_views < MIN_VIEWS or n_fruit < MIN_FRUIT:
        reason = (
            f"calibrate='hand-eye': {n_views} views and {n_fruit} fruit seen in two views or more, fewer than the "
            f"{MIN_VIEWS} views and {MIN_FRUIT} fruit a hand-eye correction needs; localised without it"
        )
        return _with_report(first, {"method": "hand-eye", "applied": False, "reason": reason})
    assert b is not None
    T = np.eye(4)
    current, fit = first, None
    for round_ in range(2):
        bb = boxes_of(corrected_problem(problem, T) if round_ else problem, current.objects, MAX_OBJECTS)  # type: ignore[arg-type]
        if bb is None:
            break
        from threadpoolctl import threadpool_limits  # a dependency of scikit-learn

        with threadpool_limits(limits=1):  # small matrices: a BLAS pool only slows them (see .diagnose)
            fit = fit_correction(bb, "hand_eye")
        s = hand_eye_summary(fit)
        if not round_ and not _reliable(fit):
            why = "the views determine the hand-eye correction too poorly to apply it"
            return _declined(first, s, fit, why, "add views from more different directions")
        if not round_ and not _beyond_noise(fit):
            why = "the views show no hand-eye error beyond the noise"
            extra = f" (distance from none {_distance(fit):.1f}, under {_quantile():.1f}: the chi-square quantile of NO_ERROR_P)"
            return _declined(first, s, fit, why, "", extra)
        if round_ and s["rotation_deg"] < NEGLIGIBLE_DEG and s["translation_mm"] < 1e3 * NEGLIGIBLE_M:
            break
        T = np.asarray(s["T_corrected_reported"]) @ T
        current = estimate(corrected_problem(problem, T))
    assert fit is not None
    report = _report(T, fit)
    return _with_report(current, report)


def _reliable(fit: Any) -> bool:
    """Whether a hand-eye fit's rotation angle and translation length are known within :data:`UNRELIABLE_DEG` and
    :data:`UNRELIABLE_M` (1-sigma along the estimate: a part the views leave free entirely, such as a shift along the
    common viewing direction, stays at zero under the prior and moves no fruit)."""
    s = hand_eye_summary(fit)
    return s["rotation_std_deg"] <= UNRELIABLE_DEG and s["translation_std_mm"] <= 1e3 * UNRELIABLE_M


def _declined(first: Estimate, s: dict[str, Any], fit: Any, why: str, advice: str, extra: str = "") -> Estimate:
    """``first`` with the report of a correction estimated and not applied, and the reason in words."""
    report = _report(np.asarray(s["T_corrected_reported"]), fit)
    found = report["note"].split(": ", 1)[1]
    reason = f"calibrate='hand-eye': {why}: {found}{extra}; localised without it" + (f": {advice}" if advice else "")
    return _with_report(
        first, {**report, "applied": False, "note": f"hand-eye correction not applied: {found}", "reason": reason}
    )


def _distance(fit: Any) -> float:
    """The squared Mahalanobis distance of a hand-eye fit's six parameters from zero (no correction); infinite where
    the covariance is not finite or singular (:func:`_reliable`, asked first, refuses those: a correction it let
    pass is then applied)."""
    theta, cov = np.asarray(fit.theta, dtype=float), np.asarray(fit.theta_cov, dtype=float)
    if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(cov))):
        return float("inf")
    try:
        return float(theta @ np.linalg.solve(cov, theta))
    except np.linalg.LinAlgError:  # pragma: no cover - a singular covariance
        return float("inf")


def _quantile() -> float:
    """The chi-square quantile (6 degrees of freedom) of :data:`NO_ERROR_P`."""
    from scipy.special import chdtri  # chi2.isf(p, dof), on first use

    return float(chdtri(6, NO_ERROR_P))


def _beyond_noise(fit: Any) -> bool:
    """Whether a hand-eye fit's correction differs from none beyond the noise (:data:`NO_ERROR_P`)."""
    return _distance(fit) > _quantile()


def _report(T: np.ndarray, last: Any) -> dict[str, Any]:
    """The applied correction ``T`` (4, 4) in words, with the uncertainty of the last round's fit."""
    from .corrections import rotvec_from_matrix

    w, t = rotvec_from_matrix(T[:3, :3]), T[:3, 3]
    total = replace(last, theta=np.concatenate([w, t]))
    s = hand_eye_summary(total)
    sd_w = np.degrees(np.sqrt(np.maximum(np.diag(last.theta_cov)[:3], 0.0)))
    sd_t = np.sqrt(np.maximum(np.diag(last.theta_cov)[3:6], 0.0))
    undetermined = [f"r{a}" for a, sd in zip("xyz", sd_w) if sd > UNDETERMINED_DEG] + [
        f"t{a}" for a, sd in zip("xyz", sd_t) if sd > UNDETERMINED_M
    ]
    return {
        "method": "hand-eye",
        "applied": True,
        **s,
        "undetermined": undetermined,
        "note": (
            f"hand-eye correction applied: {s['rotation_deg']:.2f} +- {s['rotation_std_deg']:.2f} degrees about "
            f"[{', '.join(f'{x:+.2f}' for x in s['axis_optical'])}] (optical frame) and {s['translation_mm']:.1f} +- "
            f"{s['translation_std_mm']:.1f} mm"
            + (f"; {', '.join(undetermined)} not determined by these views" if undetermined else "")
        ),
        "rotation_std_xyz_deg": [float(x) for x in sd_w],
        "translation_std_xyz_mm": [1e3 * float(x) for x in sd_t],
    }


def _with_report(est: Estimate, report: dict[str, Any]) -> Estimate:
    return replace(est, diagnostics={**est.diagnostics, "calibration": report})
