"""The ``quadric`` method on one session: association, one LfD solve per object, the result."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable

import numpy as np

from ...errors import InputError, InputWarning
from ...geometry.ellipsoid import quaternion_xyzw_from_rotation, shape_of
from ...geometry.quadric import ellipsoid_from_dual_quadric
from ...result import DetectedObject, Result
from ...session import Session
from .config import QuadricConfig
from .dual import camera_matrix, solve_dual_quadric

#: An object's association: view index -> detection index.
Association = dict[int, int]


def has_tracks(session: Session) -> bool:
    """Whether any detection of the session carries a ``track`` id."""
    return any(d.track is not None for v in session.views for d in v.detections)


def track_association(session: Session) -> tuple[list[int], list[Association]]:
    """The association given by the detections' ``track`` ids: the ids (ascending) and, per id, view -> detection.

    Detections without a track id are left out (the session loader allows one box per track and view).
    """
    by_track: dict[int, Association] = {}
    for i, view in enumerate(session.views):
        for j, det in enumerate(view.detections):
            if det.track is not None:
                by_track.setdefault(det.track, {})[i] = j
    ids = sorted(by_track)
    return ids, [by_track[t] for t in ids]


def bayes_association(session: Session, config: QuadricConfig) -> tuple[list[Association], list[str]]:
    """The association the ``bayes`` method finds (``result.objects[i].associations``), and its warnings.

    ``bayes`` is run through the methods registry, as any caller would: ``quadric`` imports no other method.
    """
    from .. import get_method

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = get_method("bayes").run(session, config.bayes_config())
    messages = [f"association (bayes): {m}" for m in result.warnings]
    messages += [f"association (bayes): {w.message}" for w in caught if str(w.message) not in result.warnings]
    return [dict(o.associations) for o in result.objects], messages


def fit_object(session: Session, association: Association) -> tuple[DetectedObject | None, str | None]:
    """LfD's ellipsoid of one object from its associated boxes (at least 3 views); a message when it is not an ellipsoid.

    Returns ``(None, message)`` when the fitted quadric has its centre at infinity.
    """
    views = sorted(association)
    P = np.stack([camera_matrix(session.camera, session.views[i].T_base_optical) for i in views])
    boxes = np.stack([session.views[i].detections[association[i]].bbox_xyxy for i in views])
    Q, sv = solve_dual_quadric(P, boxes, (session.camera.width, session.camera.height))
    extra = {"n_views": len(views), "singular_ratio": float(sv[-1] / sv[-2]) if sv[-2] > 0 else float("nan")}
    fields = {"associations": {i: association[i] for i in views}, "extra": extra}
    try:
        centre, semi_axes, R = ellipsoid_from_dual_quadric(Q)
    except InputError as exc:
        if not np.all(np.isfinite(Q)) or Q[3, 3] == 0:
            return None, f"{exc}; object left out"
        centre = -Q[:3, 3]  # Q is scaled so that Q[3, 3] = -1: the centre stands without a shape
        return DetectedObject(centre, float(len(views)), **fields), f"{exc}; its centre is reported without a shape"
    obj = DetectedObject.from_ellipsoid(
        centre, semi_axes, quaternion_xyzw_from_rotation(R), float(len(views)), shape_of(semi_axes), **fields
    )
    return obj, None


def run(session: Session, config: QuadricConfig, *, progress: Callable[[int, int], None] | None = None) -> Result:
    """The ``quadric`` method on one session (see :mod:`monovisual3d.methods.quadric`).

    Each object's score is the number of views its ellipsoid was fitted to; ``extra["singular_ratio"]``
    is the ratio of the two smallest singular values of its preconditioned system (near 0: the boxes agree
    with one ellipsoid).
    """
    t0 = time.perf_counter()
    messages: list[str] = []
    use_tracks = config.association == "tracks" or (config.association == "auto" and has_tracks(session))
    if use_tracks:
        if not has_tracks(session):
            raise InputError("association: got 'tracks', but no detection has a track id; use auto or bayes")
        ids, associations = track_association(session)
        tracks: list[int | None] = list(ids)
    else:
        associations, bayes_messages = bayes_association(session, config)
        messages += bayes_messages
        tracks = [None] * len(associations)
    t_assoc = time.perf_counter()
    if session.camera.distortion_model != "none":
        messages.append("the camera's lens distortion is ignored: LfD's dual conics assume a pinhole camera")
    objects: list[DetectedObject] = []
    skipped = 0
    for k, (track, assoc) in enumerate(zip(tracks, associations)):
        label = f"object {k} (boxes associated by bayes)" if track is None else f"track {track}"
        if len(assoc) < config.min_views:
            skipped += 1
            messages.append(f"{label}: boxes in {len(assoc)} view(s), at least min_views={config.min_views} are needed; left out")
            continue
        obj, note = fit_object(session, assoc)
        if note is not None:
            messages.append(f"{label}: {note}")
        if obj is not None:
            if track is not None:
                obj.extra["track"] = track
            objects.append(obj)
    if progress is not None:
        progress(len(session.views), len(session.views))
    for msg in messages:
        warnings.warn(InputWarning(msg), stacklevel=3)
    t1 = time.perf_counter()
    return Result(
        objects=objects,
        method="quadric",
        timing_s={"association": t_assoc - t0, "solve": t1 - t_assoc, "total": t1 - t0},
        config=config.to_dict(),
        warnings=messages,
        diagnostics={"association": "tracks" if use_tracks else "bayes", "associated": len(associations), "left_out": skipped},
    )
