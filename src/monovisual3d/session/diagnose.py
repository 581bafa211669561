"""Session-level input checks: physical tests on the input itself that name an integration mistake.

Each test looks at what a session says of the world (box coordinates against the image, poses against each other,
box-centre rays between views) and returns :class:`~monovisual3d.verdict.Cause` objects whose message names the
mistake and what to check. They run before any method, so every method and front end says the same:

- :func:`raw_box_causes`: box coordinates as written, before the loader clips them to the image: normalised
  (refused), ``y1, x1, y2, x2``, boxes past the calibration image (a larger image), boxes stretched by a square
  detector input; :func:`refusal_hint` says which convention a box the loader refuses was probably written in
  (``x, y, w, h``, swapped, a larger image);
- :func:`duplicate_views`: views given more than once (same pose and boxes), counted once;
- :func:`one_pose_causes`: every view at one pose (no baseline: depth is not observable);
- :func:`pose_convention_causes`: inverted (world-to-camera) poses, ``camera_link`` given as optical and the
  reverse: box-centre rays of two views meet in front of both cameras, at depths where the boxes' sizes agree,
  under the right convention and not under a wrong one (:func:`ray_agreement`);
- :func:`image_spread_causes`: boxes confined to the top-left part of the image around a shrunken principal point
  (boxes from a smaller image);
- :func:`distortion_causes`: distortion coefficients whose pattern no lens has (a ``k3`` in the tangential slots,
  the signs of an undistortion model).

:func:`check_session` runs them all on a loaded session (the loader's raw-box causes are in ``session.causes``) and
returns the session with duplicated views dropped and the causes found. Numpy only: part of the core.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..camera import Camera
from ..errors import InputError
from ..frames import T_cameralink_optical, invert_transform
from ..verdict import Cause
from .baseline import SAME_POSE_DEG, SAME_POSE_M
from .model import Session
from .rays import ray_agreement

# ---------------------------------------------------------------------- constants
#: Every box coordinate at most this while the image is far larger: boxes normalised to 0..1 (with some margin for
#: boxes a detector lets run past the image edge).
NORMALISED_MAX = 1.5
#: An image smaller than this (pixels, either side) could hold pixel boxes within 0..NORMALISED_MAX.
NORMALISED_MIN_IMAGE_PX = 16
#: A box past the image by more than this share of the image side lies past it beyond a detector's rounding.
PAST_EDGE_SHARE = 0.01
#: Boxes past the right or bottom edge (and none past the left or top) that say the image is larger than the
#: calibration's: at least this many, and this share of the boxes.
PAST_EDGE_MIN_BOXES = 2
PAST_EDGE_MIN_SHARE = 0.05
#: A median box aspect (height / width) within this factor of the image's own (height/width stretched to a square)
#: and at least :data:`STRETCH_MIN` away from 1: round fruit stretched by a square detector input.
#: (why: docs/decisions/input-checks.md#stretch_tolerance)
STRETCH_TOLERANCE = 1.12
STRETCH_MIN = 1.2
#: Fewest boxes for a statistic over boxes (aspect, spread) to speak.
MIN_BOXES = 6
#: (why: docs/decisions/input-checks.md#small_extent) Boxes of a smaller image: every box within this share of the
#: image (both sides) ...
SMALL_EXTENT = 0.7
#: ... and the median box centre at least this share of the image above and left of the principal point.
SMALL_OFFSET = 0.07

#: Boxes of a larger image: reaching this share of both sides, their median centre :data:`SMALL_OFFSET` of the image
#: or more below and right of the principal point.
LARGE_EXTENT = 0.9
#: Images narrower than this aspect (width / height) are the 4:3 (or squarer) sensors a 16:9 crop is taken of.
WIDE_ASPECT = 1.5
#: Boxes of a centre crop: their median centre above the principal point by at least this share of the crop's shift
#: (the rest of the shift is room for fruit that lie off-centre).
CROP_OFFSET_SHARE = 0.6

#: A convention whose rays agree on at least this share of boxes, and on this much more than the poses as given,
#: is the one the poses are in. (why: docs/decisions/input-checks.md#meet_gap_radii)
AGREE_MIN = 0.5
AGREE_MARGIN = 0.3

#: Conventions whose agreements lie within this of the best are named together: the rays cannot tell them apart.
TIE_MARGIN = 0.1
#: Boxes with x and y swapped: their rays agree on at least :data:`AGREE_MIN` of boxes, this much more than as given.
SWAP_MARGIN = 0.2

#: Tangential coefficients (p1, p2 of plumb_bob) beyond this are an order of magnitude above a real lens's.
#: (why: docs/decisions/input-checks.md#max_tangential)
MAX_TANGENTIAL = 0.01
#: A pincushion ``k1`` above this with a negative ``k2``: the sign pattern of a barrel lens's undistortion model.
FLIPPED_K1 = 0.05

#: Pose hypotheses of :func:`pose_convention_causes`: name -> what the message says.
POSE_HYPOTHESES = {
    "inverted": "inverted poses (world-to-camera, T_optical_base, e.g. OpenCV rvec/tvec or a view matrix) "
    "given where T_base_optical belongs",
    "camera_link_as_optical": "camera_link poses (x forward, y left, z up) given as the optical frame's; "
    "look up the optical frame, or set pose_frame: camera_link",
    "optical_as_camera_link": "optical-frame poses declared pose_frame: camera_link; set pose_frame: optical",
    "facing_away": "cameras facing away from the fruit (the optical axis reversed: a frame turned half a turn about "
    "its y axis); check the camera frame's axes (z forward, x right, y down)",
}
#: Half a turn about the optical y axis: the camera facing the other way.
T_FACING_AWAY = np.diag([-1.0, 1.0, -1.0, 1.0])


# ---------------------------------------------------------------------- the one entry point
def check_session(session: Session) -> tuple[Session, list[Cause]]:
    """Run every input check on a loaded session.

    Parameters
    ----------
    session : Session, as :func:`~monovisual3d.session.load.load_session` returns it (its ``causes`` hold the
        loader's findings on the boxes as written)

    Returns
    -------
    session : Session, with views that repeat an earlier one (same pose and boxes) dropped
    causes : list of Cause, the loader's and these tests' (empty on a clean session)

    Raises
    ------
    InputError
        Where the input cannot be used (never here yet: the loader refuses normalised boxes).

    Examples
    --------
    >>> from monovisual3d.sim.scenes import paper_scene
    >>> from monovisual3d.sim.simulate import simulate
    >>> session, _ = simulate(paper_scene(), rng=0)
    >>> twice = Session(session.camera, session.views + session.views)
    >>> checked, causes = check_session(twice)
    >>> len(checked.views), [c.cause for c in causes]
    (3, ['duplicate_views'])
    """
    causes = list(session.causes)
    session, repeated = duplicate_views(session)
    causes += repeated
    same = one_pose_causes(session)
    causes += same
    if not same:
        poses = pose_convention_causes(session)
        causes += poses
        if not poses and not any(c.cause == "box_coordinates" for c in causes):
            causes += swapped_box_causes(session)
    causes += image_spread_causes(session)
    causes += distortion_causes(session.camera)
    return session, causes


# ---------------------------------------------------------------------- box coordinates as written
def raw_box_causes(camera: Camera, T_base_optical: NDArray[np.float64], boxes: Sequence[NDArray[np.float64]]) -> list[Cause]:
    """Tests of the boxes as written (before clipping) against the calibration's image.

    Parameters
    ----------
    camera : Camera
    T_base_optical : ndarray, shape (N, 4, 4), the views' poses
    boxes : sequence of N arrays, shape (M_i, 4), pixels ``(x1, y1, x2, y2)`` as written

    Returns
    -------
    list of Cause (``box_coordinates`` or ``image_size``)

    Raises
    ------
    InputError
        Boxes normalised to 0..1: every coordinate within 0..:data:`NORMALISED_MAX` of a larger image.
    """
    W, H = camera.width, camera.height
    allb = _stack(boxes)
    if not len(allb):
        return []
    if min(W, H) >= NORMALISED_MIN_IMAGE_PX and np.all(np.abs(allb) <= NORMALISED_MAX):
        raise InputError(
            f"views[*].detections[*].bbox_xyxy: all {len(allb)} boxes lie within 0..{allb.max():.3g} of the {W}x{H} image: "
            f"boxes normalised to 0..1? expected pixels x1, y1, x2, y2; multiply x by {W} and y by {H}"
        )
    causes = _past_edge_causes(camera, T_base_optical, boxes, allb)
    stretch = box_stretch(allb, W, H, camera.cx, camera.cy)
    if stretch is not None:
        side = max(W, H)
        causes.append(
            Cause(
                "image_size",
                f"views[*].detections[*].bbox_xyxy: the median box is {stretch:.2f} times as tall as wide, the stretch of "
                f"the {W}x{H} image to a {side}x{side} square: boxes in the detector's input size, not scaled back "
                "to the image? check the image size the boxes are in",
                "unreliable",
                details={"median_aspect": stretch, "image_aspect": H / W},
            )
        )
    return causes


def _past_edge_causes(
    camera: Camera, T: NDArray[np.float64], boxes: Sequence[NDArray[np.float64]], allb: NDArray[np.float64]
) -> list[Cause]:
    """Boxes past the right or bottom edge: x and y swapped when that fits the image and the rays, else a larger
    image than the calibration's."""
    W, H = camera.width, camera.height
    past = past_edge_boxes(allb, W, H)
    if past is None:
        return []
    swapped = _stack([b[:, [1, 0, 3, 2]] for b in boxes])
    if past_edge_boxes(swapped, W, H) is None and np.all(_inside(swapped, W, H)) and _swap_agrees(camera, T, boxes):
        return [
            Cause(
                "box_coordinates",
                f"views[*].detections[*].bbox_xyxy: {past['n']} of {len(allb)} boxes run past the bottom of the "
                f"{W}x{H} image while every box fits it with x and y swapped, and box-centre rays agree across views "
                "so: boxes written y1, x1, y2, x2 (x and y swapped)? expected x1, y1, x2, y2",
                "unreliable",
                details={"past_edge": past["n"], "boxes": len(allb)},
            )
        ]
    return [
        Cause(
            "image_size",
            f"views[*].detections[*].bbox_xyxy: {past['n']} of {len(allb)} boxes run past the right or bottom edge "
            f"of the {W}x{H} calibration image (up to x={past['max_x']:.0f}, y={past['max_y']:.0f}) and none past the "
            "left or top: boxes from a larger image than the calibration's? check that the camera's image size "
            "(resolution) is that of the images the detector ran on, or scale the boxes",
            "unreliable",
            details={"past_edge": past["n"], "boxes": len(allb), "max_xy": [past["max_x"], past["max_y"]]},
        )
    ]


def past_edge_boxes(boxes: NDArray[np.float64], W: int, H: int) -> dict[str, float] | None:
    """Boxes past the right or bottom edge (none past the left or top): the signature of a larger image.

    Returns ``{"n", "max_x", "max_y"}`` when at least :data:`PAST_EDGE_MIN_BOXES` boxes (and
    :data:`PAST_EDGE_MIN_SHARE` of them) run past the right or bottom edge by more than :data:`PAST_EDGE_SHARE` of
    the side and none past the left or top; else None.
    """
    if not len(boxes):
        return None
    right = boxes[:, 2] > W * (1 + PAST_EDGE_SHARE)
    bottom = boxes[:, 3] > H * (1 + PAST_EDGE_SHARE)
    left_top = (boxes[:, 0] < -W * PAST_EDGE_SHARE) | (boxes[:, 1] < -H * PAST_EDGE_SHARE)
    n = int(np.sum(right | bottom))
    if np.any(left_top) or n < max(PAST_EDGE_MIN_BOXES, PAST_EDGE_MIN_SHARE * len(boxes)):
        return None
    return {"n": n, "max_x": float(boxes[:, 2].max()), "max_y": float(boxes[:, 3].max())}


def box_stretch(boxes: NDArray[np.float64], W: int, H: int, cx: float | None = None, cy: float | None = None) -> float | None:
    """The median box aspect (height / width) when it matches the stretch of the image to a square, else None.

    Round fruit give a median aspect near 1; boxes of a ``W x W`` detector input not scaled back to ``W x H`` are
    stretched by ``W / H`` in height (or ``H / W`` in width). Tall objects (containers, bottles) can have that aspect
    too; the stretch also moves every box away from the image's top (left) edge by the same factor, so with the
    principal point ``cx, cy`` given, the boxes must sit nearer it once shrunk back (the views look at what they
    detect) than as written: tall boxes around the principal point are taken as tall objects.
    """
    if W == H or len(boxes) < MIN_BOXES:
        return None
    w, h = boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]
    ok = (w > 0) & (h > 0)
    if np.sum(ok) < MIN_BOXES:
        return None
    aspect = float(np.median(h[ok] / w[ok]))
    expected = W / H  # a square input of side max(W, H) stretches the short side by max/min
    if not (abs(np.log(aspect / expected)) < np.log(STRETCH_TOLERANCE) and abs(np.log(aspect)) > np.log(STRETCH_MIN)):
        return None
    if cx is not None and cy is not None:
        axis, centre, factor = (1, cy, W / H) if W > H else (0, cx, H / W)  # the stretched axis, its principal point
        mid = float(np.median(0.5 * (boxes[ok, axis] + boxes[ok, axis + 2])))
        if abs(mid / factor - centre) >= abs(mid - centre):
            return None
    return aspect


def refusal_hint(camera: Camera, boxes: Sequence[NDArray[np.float64]]) -> str | None:
    """What convention the boxes as written are probably in, where the loader refuses one; None when unclear.

    Short (under 90 characters), for it is appended to the loader's one-line refusal.

    Parameters
    ----------
    camera : Camera
    boxes : sequence of arrays, shape (M_i, 4), the boxes as written (those that are four finite numbers)
    """
    allb = _stack(boxes)
    if not len(allb):
        return None
    W, H = camera.width, camera.height
    x1, y1, x2, y2 = allb.T
    reversed_ = (x2 <= x1) | (y2 <= y1)
    if np.mean(reversed_) >= 0.5:
        as_xywh = np.stack([x1, y1, x1 + x2, y1 + y2], axis=1)
        if np.all((x2 > 0) & (y2 > 0)) and np.mean(_inside(as_xywh, W, H)) >= 0.9:
            return f"{int(np.sum(reversed_))} of {len(allb)} boxes so, all inside read as x,y,w,h (COCO): use x, y, x + w, y + h"
        return None
    if past_edge_boxes(allb, W, H) is not None:
        swapped = allb[:, [1, 0, 3, 2]]
        if np.all(_inside(swapped, W, H)) and past_edge_boxes(swapped, W, H) is None and np.all(x2 <= H):
            return "every box fits the image with x and y swapped: boxes written y1, x1, y2, x2?"
        return f"boxes reach x={x2.max():.0f}, y={y2.max():.0f}, never left or top: from a larger image? check the image size"
    return None


def _stack(boxes: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    parts = [np.asarray(b, dtype=float).reshape(-1, 4) for b in boxes]
    return np.concatenate(parts) if parts else np.zeros((0, 4))


def _inside(boxes: NDArray[np.float64], W: int, H: int) -> NDArray[np.bool_]:
    """Boxes within the image, up to :data:`PAST_EDGE_SHARE` of a side."""
    mx, my = W * PAST_EDGE_SHARE, H * PAST_EDGE_SHARE
    return (boxes[:, 0] >= -mx) & (boxes[:, 1] >= -my) & (boxes[:, 2] <= W + mx) & (boxes[:, 3] <= H + my)


def _swap_agrees(camera: Camera, T: NDArray[np.float64], boxes: Sequence[NDArray[np.float64]]) -> bool:
    """Whether box-centre rays agree across views with x and y swapped at least as well as as given."""
    swapped = [np.asarray(b, dtype=float).reshape(-1, 4)[:, [1, 0, 3, 2]] for b in boxes]
    given, alt = ray_agreement(camera, T, boxes), ray_agreement(camera, T, swapped)
    if given is None or alt is None:
        return True  # no baseline to tell: the image bounds alone speak
    return alt >= given


def swapped_box_causes(session: Session) -> list[Cause]:
    """Boxes written ``y1, x1, y2, x2``: with x and y swapped, every box fits the image and box-centre rays agree
    across views (:func:`ray_agreement`) on :data:`SWAP_MARGIN` more of the boxes than as given."""
    cam = session.camera
    T = np.stack([v.T_base_optical for v in session.views])
    boxes = [v.boxes_xyxy for v in session.views]
    swapped = [b[:, [1, 0, 3, 2]] for b in boxes]
    allb = _stack(swapped)
    if not len(allb) or not np.all(_inside(allb, cam.width, cam.height)):
        return []
    given = ray_agreement(cam, T, boxes)
    alt = ray_agreement(cam, T, swapped)
    if given is None or alt is None or alt < AGREE_MIN or alt < given + SWAP_MARGIN:
        return []
    return [
        Cause(
            "box_coordinates",
            f"views[*].detections[*].bbox_xyxy: box-centre rays of different views meet (in front of both cameras, at "
            f"depths where the box sizes agree) for {100 * alt:.0f} % of boxes with x and y swapped, {100 * given:.0f} % "
            "as given: boxes written y1, x1, y2, x2 (x and y swapped, TensorFlow's order)? expected x1, y1, x2, y2",
            "unreliable",
            details={"agreement_given": given, "agreement_swapped": alt},
        )
    ]


# ---------------------------------------------------------------------- views
def duplicate_views(session: Session) -> tuple[Session, list[Cause]]:
    """Drop views that repeat an earlier one exactly (same pose and the same boxes), with one cause naming them.

    Returns
    -------
    session : Session, each view once (the first of each repeat kept)
    causes : list with one ``duplicate_views`` Cause, or empty
    """
    kept: list[int] = []
    repeats: dict[int, int] = {}
    keys: dict[bytes, int] = {}
    for i, v in enumerate(session.views):
        key = np.round(v.T_base_optical, 9).tobytes() + np.round(v.boxes_xyxy, 6).tobytes()
        if key in keys and len(v.detections):
            repeats[i] = keys[key]
        else:
            keys.setdefault(key, i)
            kept.append(i)
    if not repeats:
        return session, []
    dropped = sorted(repeats)
    pairs = ", ".join(f"views[{i}] = views[{repeats[i]}]" for i in dropped[:6]) + (", ..." if len(dropped) > 6 else "")
    message = (
        f"views: {len(dropped)} duplicate views (same pose and boxes as an earlier view: {pairs}); each counted once. "
        "Check the loop that collects the views (does it append views it already had?)"
    )
    out = dataclasses.replace(session, views=tuple(session.views[i] for i in kept))
    details = {"kept": kept, "same_as": [[i, repeats[i]] for i in dropped]}
    return out, [Cause("duplicate_views", message, "suspect", tuple(dropped), details)]


def views_as_given(associations: dict[int, int], causes: Sequence[Cause]) -> dict[int, int]:
    """An object's ``associations`` (view -> box) over the views :func:`check_session` kept, mapped back to the views
    as given: each duplicate view gets its original's box.

    Examples
    --------
    >>> dup = Cause("duplicate_views", "views[2] = views[0]", views=(2,), details={"kept": [0, 1], "same_as": [[2, 0]]})
    >>> views_as_given({0: 3, 1: 0}, [dup])
    {0: 3, 1: 0, 2: 3}
    """
    for c in causes:
        if c.cause == "duplicate_views" and "kept" in c.details:
            out = {int(c.details["kept"][v]): int(d) for v, d in associations.items()}
            for dup, orig in c.details["same_as"]:
                if int(orig) in out:
                    out[int(dup)] = out[int(orig)]
            return dict(sorted(out.items()))
    return dict(associations)


def one_pose_causes(session: Session) -> list[Cause]:
    """Every view (two or more) at the same pose: depth is not observable (no baseline)."""
    n = len(session.views)
    if n < 2:
        return []
    T = np.stack([v.T_base_optical for v in session.views])
    cos_rot = np.clip((np.einsum("nij,ij->n", T[:, :3, :3], T[0, :3, :3]) - 1) / 2, -1.0, 1.0)
    moved = np.linalg.norm(T[:, :3, 3] - T[0, :3, 3], axis=1)
    if np.all(moved < SAME_POSE_M) and np.all(np.degrees(np.arccos(cos_rot)) < SAME_POSE_DEG):
        return [
            Cause(
                "one_pose",
                f"views: all {n} views at the same pose (no baseline): depth is not observable and no position can be "
                "trusted. Check that each view's pose is read at its image's time (a stale TF, a variable not updated "
                "in the loop)",
                "unreliable",
                tuple(range(n)),
            )
        ]
    return []


# ---------------------------------------------------------------------- poses
def pose_hypothesis(T_base_optical: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """The poses (N, 4, 4) the loaded poses would be if they were written in the convention ``name`` of
    :data:`POSE_HYPOTHESES` (``given``: as loaded)."""
    T = np.asarray(T_base_optical, dtype=float)
    if name == "given":
        return T
    if name == "inverted":
        return np.stack([invert_transform(t) for t in T])
    if name == "camera_link_as_optical":  # what was read as T_base_optical is T_base_cameralink
        return T @ T_cameralink_optical()
    if name == "optical_as_camera_link":  # the loader turned an optical pose as if it were camera_link's
        return T @ invert_transform(T_cameralink_optical())
    if name == "facing_away":
        return T @ T_FACING_AWAY
    raise ValueError(f"name: got {name!r}, expected 'given' or one of {sorted(POSE_HYPOTHESES)}")


def pose_convention_causes(session: Session) -> list[Cause]:
    """Poses in another convention: box-centre rays agree across views under it, not as given.

    Returns
    -------
    list with one ``pose_convention`` Cause naming the convention, or empty
    """
    T = np.stack([v.T_base_optical for v in session.views]) if session.views else np.zeros((0, 4, 4))
    boxes = [v.boxes_xyxy for v in session.views]
    given = ray_agreement(session.camera, T, boxes)
    if given is None or given >= 1.0 - AGREE_MARGIN:
        return []
    scores = {name: ray_agreement(session.camera, pose_hypothesis(T, name), boxes) for name in POSE_HYPOTHESES}
    ranked = sorted(((v, k) for k, v in scores.items() if v is not None), key=lambda vk: -vk[0])  # stable: list order
    if not ranked or ranked[0][0] < AGREE_MIN or ranked[0][0] < given + AGREE_MARGIN:
        return []
    best = ranked[0][0]
    named = [(v, k) for v, k in ranked if v >= best - TIE_MARGIN]  # conventions the rays cannot tell apart
    read_as = ", ".join(f"{100 * v:.0f} % read as {k.replace('_', ' ')}" for v, k in named)
    read_as = read_as.replace(" % read as", " % of boxes with the poses read as", 1)
    return [
        Cause(
            "pose_convention",
            f"views[*].pose: box-centre rays of different views meet (in front of both cameras, at depths where the "
            f"box sizes agree) for {read_as}, {100 * given:.0f} % as given: "
            + "; or ".join(POSE_HYPOTHESES[k] for _, k in named),
            "unreliable",
            details={"agreement_given": given, **{f"agreement_{k}": v for k, v in scores.items()}},
        )
    ]


# ---------------------------------------------------------------------- image spread
def image_spread_causes(session: Session) -> list[Cause]:
    """Boxes of a smaller image, or of a crop of the calibration's image, told by where the boxes lie.

    Cameras aimed at the fruit see them around the principal point. Boxes of an image ``s`` times smaller lie around
    the principal point scaled by ``s`` towards the origin, within the top-left ``s`` of the image: every box within
    :data:`SMALL_EXTENT` of both sides, the median box centre :data:`SMALL_OFFSET` of the image or more above and
    left of the principal point. Boxes of a larger image lie around a point as far below and right of it, and reach
    the right and bottom edges (:data:`LARGE_EXTENT`); those past the edges are told by :func:`raw_box_causes`. Boxes of a 16:9 centre crop of a 4:3 (or squarer) sensor lie shifted up by the
    rows cut above the crop, within the crop's height: every box within it, the median centre above the principal
    point by :data:`CROP_OFFSET_SHARE` of the shift or more. A crop of a wider sensor's width (4:3 of 16:9) shifts
    the boxes sideways, where fruit off to one side of an arc of views lie too: that is left to the fit's offset
    pattern (docs/trust.md).
    """
    cam = session.camera
    allb = _stack([v.boxes_xyxy for v in session.views])
    if len(allb) < MIN_BOXES:
        return []
    W, H = cam.width, cam.height
    ex, ey = allb[:, 2].max() / W, allb[:, 3].max() / H
    ox = (np.median(0.5 * (allb[:, 0] + allb[:, 2])) - cam.cx) / W
    oy = (np.median(0.5 * (allb[:, 1] + allb[:, 3])) - cam.cy) / H
    details = {"extent": [float(ex), float(ey)], "median_offset": [float(ox), float(oy)]}
    if max(ex, ey) < SMALL_EXTENT and ox < -SMALL_OFFSET and oy < -SMALL_OFFSET:
        return [
            Cause(
                "image_size",
                f"views[*].detections: every box lies within the top-left {100 * ex:.0f} % x {100 * ey:.0f} % of the "
                f"{W}x{H} image, around a point {100 * -ox:.0f} % / {100 * -oy:.0f} % of the image above and left of the "
                "principal point: boxes from a smaller image (another resolution) than the calibration's? check the "
                "image size the detector ran on, or scale the boxes",
                "suspect",
                details=details,
            )
        ]
    if min(ex, ey) > LARGE_EXTENT and ox > SMALL_OFFSET and oy > SMALL_OFFSET:
        return [
            Cause(
                "image_size",
                f"views[*].detections: the boxes lie around a point {100 * ox:.0f} % / {100 * oy:.0f} % of the image "
                f"below and right of the principal point and reach the right and bottom edges of the {W}x{H} image: "
                "boxes from a larger image (another resolution) than the calibration's? check the image size the "
                "detector ran on, or scale the boxes",
                "suspect",
                details=details,
            )
        ]
    return _crop_causes(cam, float(ey), float(oy), details)


def _crop_causes(cam: Camera, ey: float, oy: float, details: dict[str, list[float]]) -> list[Cause]:
    """A 16:9 centre crop of a 4:3 (or squarer) sensor: every box within the crop's height (``ey``: the boxes'
    bottom, a share of the height), their median centre ``oy`` (a share of the height) above the principal point."""
    W, H = cam.width, cam.height
    if W / H < WIDE_ASPECT:
        h = round(W * 9 / 16)
        shift = (H - h) / 2 / H
        if h < H and ey <= h / H + PAST_EDGE_SHARE and oy < -CROP_OFFSET_SHARE * shift:
            return [
                Cause(
                    "image_size",
                    f"views[*].detections: every box lies within the top {h} rows of the {W}x{H} image, around a point "
                    f"{100 * -oy:.0f} % of the image above the principal point: boxes from a {W}x{h} (16:9) centre crop "
                    f"of the {W}x{H} sensor under its full calibration? check the image size and crop the camera "
                    f"streams; move the principal point up by {(H - h) / 2:.0f} px for the crop",
                    "suspect",
                    details=details,
                )
            ]
    return []


# ---------------------------------------------------------------------- distortion
def distortion_causes(camera: Camera) -> list[Cause]:
    """Distortion coefficients in a pattern no lens has: tangential terms an order of magnitude too large (a ``k3``
    in a ``p`` slot: ``k1, k2, k3, p1, p2`` order), or the signs of a barrel lens's undistortion model (pincushion
    ``k1`` with a negative ``k2``)."""
    if camera.distortion_model not in ("plumb_bob", "rational_polynomial") or len(camera.distortion_coefficients) < 4:
        return []
    c = camera.distortion_coefficients
    k1, k2, p1, p2 = c[:4]
    found = []
    if max(abs(p1), abs(p2)) > MAX_TANGENTIAL:
        found.append(
            f"tangential p1, p2 = {p1:.3g}, {p2:.3g}, beyond the {MAX_TANGENTIAL:g} of a real lens: coefficients in the "
            "order k1, k2, k3, p1, p2? OpenCV's order is k1, k2, p1, p2, k3"
        )
    if k1 > FLIPPED_K1 and k2 < 0:
        found.append(
            f"k1 = {k1:.3g} > 0 with k2 = {k2:.3g} < 0, the sign pattern of a barrel lens's undistortion model: "
            "coefficients with flipped signs? OpenCV's model maps undistorted to distorted points"
        )
    if not found:
        return []
    return [
        Cause(
            "distortion",
            "camera.distortion.coefficients: " + "; ".join(found) + "; check the distortion coefficients",
            "suspect",
            details={"coefficients": list(c)},
        )
    ]
