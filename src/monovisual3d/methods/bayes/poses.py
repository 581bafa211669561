"""The ``poses`` pass: with a stated pose uncertainty, the spheres refined jointly with a pose correction per view.

Each view's reported camera pose may be off by the stated ``pose_sigma_mm`` / ``pose_sigma_deg``; the objects' boxes
in every view then say where each pose is: :func:`bundle` refines all objects seen as spheres together with one
correction per view (:mod:`.bundle`), and reports the corrections (``Result.pose_corrections``). Objects found as
spheroids keep their own fit.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ...frames import invert_transform
from .bundle import bundle_adjust, correction_transform
from .problem import Problem
from .refine import Observation
from .state import Found, State


def bundle(problem: Problem, objects: list[Found]) -> tuple[list[Found], list[dict[str, Any]]]:
    """Refine all objects jointly with a pose correction per view (:mod:`.bundle`).

    Returns the objects (an object whose joint solution diverged keeps its own)
    and, per view with detections, its estimated pose correction: ``view``
    (index in the session), ``rotvec_optical_rad`` and ``translation_optical_m``
    (``p_optical_true = exp([rotvec]x) @ p_optical_reported + translation``),
    their posterior std ``std_rotvec_optical_rad`` and ``std_translation_optical_m``,
    and ``T_base_optical_corrected`` (4x4 nested lists).
    """
    cfg, views = problem.config, problem.views
    obs = [
        (i, v, Observation(vd.T_optical_base, vd.boxes[j], vd.contours[j] if cfg.use_masks else None))
        for i, o in enumerate(objects)
        for v, vd in enumerate(views)
        if (j := o.associations.get(vd.index, -1)) >= 0
    ]
    b = bundle_adjust(
        problem.camera,
        obs,
        np.stack([o.position for o in objects]),
        np.array([float(o.radius) for o in objects]),  # type: ignore[arg-type]
        problem.model,
        position_sigma=cfg.pose_position_sigma,
        rotation_sigma=cfg.pose_rotation_sigma,
        use_masks=cfg.use_masks,
        n_views=len(views),
    )
    out = []
    for i, o in enumerate(objects):
        lo, hi = cfg.fit_radius_range
        if not (np.all(np.isfinite(b.centres[i])) and lo <= b.radii[i] <= hi):
            out.append(o)  # keep the per-object solution rather than a diverged joint one
            continue
        learned = {**o.learned(), "radius_std": float(b.radius_std[i]), "pose_corrected": True}
        out.append(Found(b.centres[i], o.score, float(b.radii[i]), b.covariances[i], o.associations, o.n_cells, **learned))
    corrections = []
    for v, vd in enumerate(views):
        T_corrected = correction_transform(b.rotvec_optical[v], b.translation_optical[v]) @ vd.T_optical_base
        corrections.append(
            {
                "view": vd.index,
                "rotvec_optical_rad": b.rotvec_optical[v].tolist(),
                "translation_optical_m": b.translation_optical[v].tolist(),
                "std_rotvec_optical_rad": b.pose_std[v, :3].tolist(),
                "std_translation_optical_m": b.pose_std[v, 3:].tolist(),
                "T_base_optical_corrected": invert_transform(T_corrected).tolist(),
            }
        )
    return out, corrections


def run(problem: Problem, state: State) -> State:
    """The pass: the spheres through :func:`bundle` (objects found as spheroids keep their own fit), and the views'
    pose corrections."""
    spheres = [o for o in state.objects if o.semi_up is None]
    if not spheres:
        return state
    refined, corrections = bundle(problem, spheres)
    objects = refined + [o for o in state.objects if o.semi_up is not None]
    return replace(state.with_objects(objects), pose_corrections=tuple(corrections))
