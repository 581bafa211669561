"""Integration mistakes, simulated: a correct session in, the session a robot integrator really writes out.

Every mistake is a pure function of the session as written (the JSON object of
:meth:`~monovisual3d.session.Session.to_dict`: what an integrator's code writes to ``session.json``), so that it
can produce what no :class:`~monovisual3d.session.Session` holds (a box ``x, y, w, h`` whose ``w`` is smaller than
its ``x``): the loader then refuses it, as it would refuse the file. The input is never changed. Functions that
draw take ``rng``; the others are deterministic.

:data:`MISTAKES` registers each mistake class with its cause (the ``quality`` cause ID a diagnosis names it by),
the words a warning must contain to name it, and what the mistake needs: views along a path (``"path"``: time
offsets) or a camera with lens distortion (``"distortion"``). ``monovisual3d bench trust`` runs them all.

Examples
--------
>>> from monovisual3d.sim.scenes import paper_scene
>>> from monovisual3d.sim.simulate import simulate
>>> session, _ = simulate(paper_scene(), rng=0)
>>> bad = normalised_boxes(session.to_dict())
>>> max(max(d["bbox_xyxy"]) for v in bad["views"] for d in v["detections"]) <= 1.0
True
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from ..errors import InputError
from ..frames import T_cameralink_optical, invert_transform, position_quaternion_from_transform
from ..io.poses import interpolate_poses
from ..session.load import pose_from_dict
from .motion import FrameTimes

#: A session as written: the JSON object of ``Session.to_dict()``.
SessionDict = dict[str, Any]

#: Largest gap (seconds) between an image's shifted stamp and the stream samples used for its pose.
STREAM_MAX_GAP_S = 1.0
#: Narrowest box (pixels) a detector still reports once a crop has cut it.
MIN_BOX_PX = 1.0


# ---------------------------------------------------------------------- helpers
def poses_of(session: SessionDict) -> NDArray[np.float64]:
    """The views' poses as written, ``T_base_<pose_frame>``, shape (N, 4, 4)."""
    return np.stack([pose_from_dict(v["pose"], f"views[{i}].pose") for i, v in enumerate(session["views"])])


def _with_poses(session: SessionDict, T: ArrayLike) -> SessionDict:
    """A copy of ``session`` with every view's pose replaced by ``T`` (N, 4, 4)."""
    out = copy.deepcopy(session)
    for view, Ti in zip(out["views"], np.asarray(T, dtype=float)):
        position, q = position_quaternion_from_transform(Ti)
        view["pose"] = {"position": position.tolist(), "quaternion_xyzw": q.tolist()}
    return out


def _map_boxes(session: SessionDict, fn: Callable[[NDArray[np.float64]], NDArray[np.float64] | None]) -> SessionDict:
    """A copy of ``session`` with each box replaced by ``fn(box)`` (4,), or dropped where ``fn`` returns None."""
    out = copy.deepcopy(session)
    for view in out["views"]:
        kept = []
        for det in view["detections"]:
            box = fn(np.asarray(det["bbox_xyxy"], dtype=float))
            if box is not None:
                kept.append({**det, "bbox_xyxy": [float(v) for v in box]})
        view["detections"] = kept
    return out


def _image_size(session: SessionDict) -> tuple[int, int]:
    cam = session["camera"]
    return int(cam["width"]), int(cam["height"])


def _check_view(session: SessionDict, index: int, where: str) -> int:
    n = len(session["views"])
    if not (isinstance(index, (int, np.integer)) and 0 <= index < n):
        raise InputError(f"{where}: got {index!r}, expected a view index in 0..{n - 1}")
    return int(index)


# ---------------------------------------------------------------------- image size
def boxes_from_resized_images(session: SessionDict, image_size: tuple[int, int]) -> SessionDict:
    """Boxes from whole images of another size, stretched, under the calibration of the original size.

    The mistake: the camera was calibrated at one resolution (1920x1080) and the detector ran on the stream at
    another (1280x720), or on its own input size (a 640x640 stretch), and nobody scaled the boxes back. Each box is
    scaled by ``image_size / calibration size`` per axis; the camera stays.
    """
    W, H = _image_size(session)
    w, h = image_size
    scale = np.array([w / W, h / H, w / W, h / H])
    return _map_boxes(session, lambda box: box * scale)


def boxes_from_centre_crop(session: SessionDict, crop_size: tuple[int, int]) -> SessionDict:
    """Boxes from a centre crop of the calibration image (a 16:9 crop of a 4:3 sensor), under the full calibration.

    The mistake: the camera driver crops the sensor's image (640x480 to 640x360) and the calibration of the full
    sensor is used as is, without moving the principal point. Boxes are shifted into the crop's pixels, clipped to
    it; a box the crop leaves narrower than :data:`MIN_BOX_PX` is dropped (the detector never saw it).
    """
    W, H = _image_size(session)
    w, h = crop_size
    if not (0 < w <= W and 0 < h <= H):
        raise InputError(f"crop_size: got {crop_size!r}, expected a size within the {W}x{H} image")
    x0, y0 = (W - w) / 2, (H - h) / 2

    def crop(box: NDArray[np.float64]) -> NDArray[np.float64] | None:
        b = np.clip(box - [x0, y0, x0, y0], 0.0, [w, h, w, h])
        return b if b[2] - b[0] >= MIN_BOX_PX and b[3] - b[1] >= MIN_BOX_PX else None

    return _map_boxes(session, crop)


def other_aspect_crop(image_size: tuple[int, int]) -> tuple[int, int]:
    """The centre crop a driver makes of a sensor of ``image_size``: 16:9 of a 4:3 (or squarer) one, else 4:3.

    Examples
    --------
    >>> other_aspect_crop((640, 480)), other_aspect_crop((1280, 720))
    ((640, 360), (960, 720))
    """
    W, H = image_size
    return (W, round(W * 9 / 16)) if W / H < 1.5 else (round(H * 4 / 3), H)


# ---------------------------------------------------------------------- box coordinates
def normalised_boxes(session: SessionDict) -> SessionDict:
    """Boxes normalised to 0..1 by the image size (a YOLO/TensorFlow output written as if in pixels)."""
    W, H = _image_size(session)
    return _map_boxes(session, lambda box: box / [W, H, W, H])


def yxyx_boxes(session: SessionDict) -> SessionDict:
    """Boxes written ``y1, x1, y2, x2`` (TensorFlow's object-detection order) in the ``x1, y1, x2, y2`` field."""
    return _map_boxes(session, lambda box: box[[1, 0, 3, 2]])


def xywh_boxes(session: SessionDict) -> SessionDict:
    """Boxes written ``x, y, w, h`` (COCO's order, top-left corner and size) in the ``x1, y1, x2, y2`` field."""
    return _map_boxes(session, lambda box: np.array([box[0], box[1], box[2] - box[0], box[3] - box[1]]))


# ---------------------------------------------------------------------- poses
def hand_eye_offset(rotation_deg: float, translation_mm: float, rng: np.random.Generator | int | None = None) -> NDArray:
    """A hand-eye calibration error ``E`` (4, 4, optical frame): a rotation of exactly ``rotation_deg`` about a
    random axis and a translation of exactly ``translation_mm`` in a random direction.

    Examples
    --------
    >>> E = hand_eye_offset(2.0, 10.0, rng=0)
    >>> round(float(np.degrees(Rotation.from_matrix(E[:3, :3]).magnitude())), 6), round(float(np.linalg.norm(E[:3, 3])), 6)
    (2.0, 0.01)
    """
    rng = np.random.default_rng(rng)
    axis = rng.normal(size=3)
    direction = rng.normal(size=3)
    E = np.eye(4)
    E[:3, :3] = Rotation.from_rotvec(math.radians(rotation_deg) * axis / np.linalg.norm(axis)).as_matrix()
    E[:3, 3] = 1e-3 * translation_mm * direction / np.linalg.norm(direction)
    return E


def hand_eye_error(session: SessionDict, E: ArrayLike) -> SessionDict:
    """Every view's pose times one camera-frame error ``E`` (4, 4): a wrong hand-eye calibration ``T_ee_optical``.

    The mistake: a hand-eye calibration off by a degree or a centimetre, or a camera mount bumped since. The same
    ``E`` sits in every view (``T_base_ee @ T_ee_optical @ E``), so it does not average out over views.
    """
    return _with_poses(session, poses_of(session) @ np.asarray(E, dtype=float))


def poses_shifted_by_frames(session: SessionDict, shift: int) -> SessionDict:
    """Each view reports the pose of the view ``shift`` frames later (earlier when negative): poses a frame late.

    The mistake: images matched to the pose stream with a time offset of whole frames (a camera driver's
    latency, stamps taken on arrival) along views taken while moving. Beyond the last (first) view the camera is
    taken to go on with the constant motion between the two end views, exact along an arc or a row.
    """
    T = poses_of(session)
    n = len(T)
    if n < 2:
        raise InputError("session: poses a frame late need at least 2 views")
    step_fwd = invert_transform(T[-2]) @ T[-1]
    step_back = invert_transform(T[1]) @ T[0]
    out = []
    for k in range(n):
        j = k + int(shift)
        if 0 <= j < n:
            out.append(T[j])
        elif j >= n:
            out.append(T[-1] @ np.linalg.matrix_power(step_fwd, j - n + 1))
        else:
            out.append(T[0] @ np.linalg.matrix_power(step_back, -j))
    return _with_poses(session, np.stack(out))


def poses_at_time_offset(session: SessionDict, frames: FrameTimes, time_offset_s: float) -> SessionDict:
    """Each view's pose interpolated in the pose stream at its image stamp plus ``time_offset_s``.

    The mistake: a pose stream and images on clocks ``time_offset_s`` apart (an unsynchronised camera, a late
    TF), matched by stamp. The stream is ``frames``' (:func:`~monovisual3d.sim.motion.frame_times`), interpolated
    as ``monovisual3d import`` does (linear in position, slerp in rotation).
    """
    stamps = np.asarray(frames.stamps, dtype=float) + time_offset_s
    T, ok, reasons = interpolate_poses(frames.stream_stamps, frames.stream_T_base_optical, stamps, STREAM_MAX_GAP_S)
    if not np.all(ok):
        i = int(np.flatnonzero(~ok)[0])
        raise InputError(f"time_offset_s: image {i} at {stamps[i]:.3f} s has no pose in the stream ({reasons[i]})")
    return _with_poses(session, T)


def inverted_poses(session: SessionDict) -> SessionDict:
    """World-to-camera poses ``T_optical_base`` written where ``T_base_optical`` belongs (an OpenCV ``rvec, tvec``
    or a view matrix taken for the camera's pose)."""
    return _with_poses(session, np.stack([invert_transform(T) for T in poses_of(session)]))


def camera_link_as_optical(session: SessionDict) -> SessionDict:
    """The ROS ``camera_link`` pose (x forward, y left, z up) written as the optical frame's (``pose_frame: optical``).

    The mistake: the TF lookup asked for ``camera_link`` instead of ``camera_optical_frame``.
    """
    T_optical_cameralink = invert_transform(T_cameralink_optical())
    return _with_poses(session, poses_of(session) @ T_optical_cameralink)


def optical_as_camera_link(session: SessionDict) -> SessionDict:
    """Optical-frame poses declared as ``pose_frame: camera_link`` (the reverse of :func:`camera_link_as_optical`)."""
    out = copy.deepcopy(session)
    out["pose_frame"] = "camera_link"
    return out


def all_views_one_pose(session: SessionDict, view: int = 0) -> SessionDict:
    """Every view given the pose of ``view``: a pose read once (a stale TF, a variable not updated in the loop)."""
    view = _check_view(session, view, "view")
    T = poses_of(session)
    return _with_poses(session, np.repeat(T[view : view + 1], len(T), axis=0))


# ---------------------------------------------------------------------- views
def boxes_from_other_view(session: SessionDict, view: int, other: int) -> SessionDict:
    """View ``view`` holds the boxes of view ``other``'s image (an image list off by one, a file saved twice)."""
    view, other = _check_view(session, view, "view"), _check_view(session, other, "other")
    out = copy.deepcopy(session)
    out["views"][view]["detections"] = copy.deepcopy(session["views"][other]["detections"])
    return out


def swapped_boxes(session: SessionDict, view: int, other: int) -> SessionDict:
    """Views ``view`` and ``other`` hold each other's boxes (two detection files saved under each other's names)."""
    view, other = _check_view(session, view, "view"), _check_view(session, other, "other")
    out = copy.deepcopy(session)
    out["views"][view]["detections"] = copy.deepcopy(session["views"][other]["detections"])
    out["views"][other]["detections"] = copy.deepcopy(session["views"][view]["detections"])
    return out


def pose_of_other_view(session: SessionDict, view: int, other: int) -> SessionDict:
    """View ``view`` holds the pose of view ``other`` (a wrong pose: a copy-paste, an index off by one)."""
    view, other = _check_view(session, view, "view"), _check_view(session, other, "other")
    out = copy.deepcopy(session)
    out["views"][view]["pose"] = copy.deepcopy(session["views"][other]["pose"])
    return out


def swapped_poses(session: SessionDict, view: int, other: int) -> SessionDict:
    """Views ``view`` and ``other`` hold each other's pose (two images saved under each other's names)."""
    view, other = _check_view(session, view, "view"), _check_view(session, other, "other")
    out = copy.deepcopy(session)
    out["views"][view]["pose"] = copy.deepcopy(session["views"][other]["pose"])
    out["views"][other]["pose"] = copy.deepcopy(session["views"][view]["pose"])
    return out


def views_twice(session: SessionDict) -> SessionDict:
    """Every view given twice, the list appended to itself (a loop that appends the views it already had)."""
    out = copy.deepcopy(session)
    out["views"] = copy.deepcopy(session["views"]) + copy.deepcopy(session["views"])
    return out


# ---------------------------------------------------------------------- distortion
def _plumb_bob(session: SessionDict) -> list[float]:
    dist = session["camera"].get("distortion")
    coeffs = list(dist["coefficients"]) if dist else []
    if dist is None or dist.get("model", "plumb_bob") not in ("plumb_bob", "radtan") or len(coeffs) != 5:
        raise InputError("camera.distortion: expected the plumb_bob model with 5 coefficients k1, k2, p1, p2, k3")
    return coeffs


def distortion_wrong_order(session: SessionDict) -> SessionDict:
    """OpenCV's ``k1, k2, p1, p2, k3`` written in the order ``k1, k2, k3, p1, p2`` (a calibration tool's own order)."""
    k1, k2, p1, p2, k3 = _plumb_bob(session)
    out = copy.deepcopy(session)
    out["camera"]["distortion"]["coefficients"] = [k1, k2, k3, p1, p2]
    return out


def distortion_flipped_signs(session: SessionDict) -> SessionDict:
    """Every distortion coefficient with its sign flipped (an undistortion model's coefficients taken for OpenCV's)."""
    out = copy.deepcopy(session)
    out["camera"]["distortion"]["coefficients"] = [-c for c in _plumb_bob(session)]
    return out


# ---------------------------------------------------------------------- registry
@dataclass(frozen=True)
class MistakeInputs:
    """What a mistake may need besides the correct session.

    Attributes
    ----------
    session : dict, the correct session as written (``Session.to_dict()``)
    frames : FrameTimes or None, the views as frames along a path with the pose stream (time offsets need it)
    """

    session: SessionDict
    frames: FrameTimes | None = None


@dataclass(frozen=True)
class Mistaken:
    """A mistaken session and what names its cause.

    Attributes
    ----------
    session : dict, the session as the integrator wrote it
    words : tuple of str, a warning or error that contains any of them (case-insensitive) names the cause
    details : dict, what was drawn (plain JSON values: the view, the hand-eye error, the offset)
    """

    session: SessionDict
    words: tuple[str, ...]
    details: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Mistake:
    """One mistake class of :data:`MISTAKES`.

    Attributes
    ----------
    name : str
    cause : str, the ``quality`` cause ID a diagnosis names it by
    summary : str, the real mistake in a few words
    make : callable (MistakeInputs, Generator) -> Mistaken
    needs : frozenset of str, ``"path"`` (views along a path with their pose stream), ``"distortion"``
        (a camera with 5 plumb_bob coefficients)
    """

    name: str
    cause: str
    summary: str
    make: Callable[[MistakeInputs, np.random.Generator], Mistaken]
    needs: frozenset[str] = frozenset()


#: The words that name each cause (case-insensitive) where the mistake adds none of its own.
CAUSE_WORDS: dict[str, tuple[str, ...]] = {
    "image_size": ("image size", "crop", "resolution"),
    "box_coordinates": ("normalised", "normalized", "swapped", "x,y,w,h"),
    "hand_eye": ("hand-eye",),
    "time_offset": ("time offset",),
    "duplicate_views": ("duplicate",),
    "distortion": ("distortion",),
    "one_pose": ("same pose",),
}


def _fixed(cause: str, fn: Callable[[SessionDict], SessionDict], words: tuple[str, ...] | None = None) -> Callable:
    """A ``make`` for a deterministic mistake ``fn(session)``, named by ``words`` (default: the cause's)."""

    def make(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
        return Mistaken(fn(inputs.session), words or CAUSE_WORDS[cause])

    return make


def _resized(size_of: Callable[[int, int], tuple[int, int]]) -> Callable:
    """A ``make`` for boxes from images of ``size_of(W, H)`` under the ``W x H`` calibration."""

    def make(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
        size = size_of(*_image_size(inputs.session))
        return Mistaken(boxes_from_resized_images(inputs.session, size), CAUSE_WORDS["image_size"], {"image_size": size})

    return make


def _cropped(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
    size = other_aspect_crop(_image_size(inputs.session))
    return Mistaken(boxes_from_centre_crop(inputs.session, size), CAUSE_WORDS["image_size"], {"crop_size": size})


def _hand_eye(rotation_deg: float, translation_mm: float) -> Callable:
    def make(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
        E = hand_eye_offset(rotation_deg, translation_mm, rng)
        return Mistaken(hand_eye_error(inputs.session, E), CAUSE_WORDS["hand_eye"], {"E_hand_eye": E.tolist()})

    return make


def _shifted(shift: int) -> Callable:
    def make(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
        return Mistaken(poses_shifted_by_frames(inputs.session, shift), CAUSE_WORDS["time_offset"], {"frames": shift})

    return make


def _streamed(frames_late: float) -> Callable:
    def make(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
        if inputs.frames is None:
            raise InputError("frames: a time offset in the pose stream needs the views' frames (views along a path)")
        offset = frames_late / inputs.frames.frame_rate_hz
        bad = poses_at_time_offset(inputs.session, inputs.frames, offset)
        return Mistaken(bad, CAUSE_WORDS["time_offset"], {"time_offset_s": offset})

    return make


def _one_view(fn: Callable[[SessionDict, int, int], SessionDict], both: bool = False) -> Callable:
    """A ``make`` that draws a view and another one; named by the wrong view (``views[N]``; either, with ``both``)."""

    def make(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
        n = len(inputs.session["views"])
        view = int(rng.integers(n))
        other = int((view + rng.integers(1, n)) % n)
        words = (f"views[{view}]", f"views[{other}]") if both else (f"views[{view}]",)
        return Mistaken(fn(inputs.session, view, other), words, {"view": view, "other": other})

    return make


def _one_pose(inputs: MistakeInputs, rng: np.random.Generator) -> Mistaken:
    view = int(rng.integers(len(inputs.session["views"])))
    return Mistaken(all_views_one_pose(inputs.session, view), CAUSE_WORDS["one_pose"], {"view": view})


_ENTRIES = (
    Mistake(
        "image-size-smaller",
        "image_size",
        "boxes from 2/3-size images (1280x720 for a 1920x1080 calibration)",
        _resized(lambda W, H: (round(W * 2 / 3), round(H * 2 / 3))),
    ),
    Mistake(
        "image-size-larger",
        "image_size",
        "boxes from 1.5x-size images (1920x1080 for a 1280x720 calibration)",
        _resized(lambda W, H: (round(W * 1.5), round(H * 1.5))),
    ),
    Mistake(
        "detector-input-size",
        "image_size",
        "boxes in the detector's square input (a W x W stretch), not scaled back",
        _resized(lambda W, H: (max(W, H), max(W, H))),
    ),
    Mistake("centre-crop", "image_size", "boxes from a centre crop (16:9 of a 4:3 sensor), full-sensor calibration", _cropped),
    Mistake("boxes-normalised", "box_coordinates", "boxes normalised to 0..1", _fixed("box_coordinates", normalised_boxes)),
    Mistake("boxes-yxyx", "box_coordinates", "boxes as y1, x1, y2, x2", _fixed("box_coordinates", yxyx_boxes)),
    Mistake("boxes-xywh", "box_coordinates", "boxes as x, y, w, h", _fixed("box_coordinates", xywh_boxes)),
    Mistake("hand-eye-2deg", "hand_eye", "hand-eye calibration rotated 2 degrees", _hand_eye(2.0, 0.0)),
    Mistake("hand-eye-1cm", "hand_eye", "hand-eye calibration shifted 1 cm", _hand_eye(0.0, 10.0)),
    Mistake("hand-eye-2deg-1cm", "hand_eye", "hand-eye calibration off by 2 degrees and 1 cm", _hand_eye(2.0, 10.0)),
    Mistake("poses-frame-late", "time_offset", "each pose that of the next frame", _shifted(1), frozenset({"path"})),
    Mistake("poses-frame-early", "time_offset", "each pose that of the previous frame", _shifted(-1), frozenset({"path"})),
    Mistake(
        "poses-half-frame-late",
        "time_offset",
        "poses interpolated half a frame late in the pose stream",
        _streamed(0.5),
        frozenset({"path"}),
    ),
    Mistake("boxes-of-other-view", "view_disagrees", "one view holds another image's boxes", _one_view(boxes_from_other_view)),
    Mistake(
        "swapped-boxes",
        "view_disagrees",
        "two views hold each other's boxes",
        _one_view(swapped_boxes, both=True),
    ),
    Mistake("pose-of-other-view", "view_disagrees", "one view holds another view's pose", _one_view(pose_of_other_view)),
    Mistake("swapped-poses", "view_disagrees", "two views hold each other's pose", _one_view(swapped_poses, both=True)),
    Mistake("views-twice", "duplicate_views", "every view given twice", _fixed("duplicate_views", views_twice)),
    Mistake(
        "poses-inverted", "pose_convention", "world-to-camera poses", _fixed("pose_convention", inverted_poses, ("inverted",))
    ),
    Mistake(
        "camera-link-as-optical",
        "pose_convention",
        "camera_link poses as optical",
        _fixed("pose_convention", camera_link_as_optical, ("camera_link",)),
    ),
    Mistake(
        "optical-as-camera-link",
        "pose_convention",
        "optical poses declared camera_link",
        _fixed("pose_convention", optical_as_camera_link, ("camera_link",)),
    ),
    Mistake(
        "distortion-order",
        "distortion",
        "distortion as k1, k2, k3, p1, p2",
        _fixed("distortion", distortion_wrong_order),
        frozenset({"distortion"}),
    ),
    Mistake(
        "distortion-signs",
        "distortion",
        "distortion coefficients with flipped signs",
        _fixed("distortion", distortion_flipped_signs),
        frozenset({"distortion"}),
    ),
    Mistake("one-pose", "one_pose", "every view at one view's pose", _one_pose),
)

#: Every mistake class by name, in the order of the issue's table.
MISTAKES: dict[str, Mistake] = {m.name: m for m in _ENTRIES}


def applies(mistake: Mistake, inputs: MistakeInputs) -> bool:
    """Whether ``inputs`` have what ``mistake`` needs (views along a path; a camera with 5 plumb_bob coefficients)."""
    if "path" in mistake.needs and inputs.frames is None:
        return False
    if "distortion" in mistake.needs:
        dist = inputs.session["camera"].get("distortion")
        return bool(dist) and dist.get("model") in ("plumb_bob", "radtan") and len(dist.get("coefficients", ())) == 5
    return True


def make_mistake(name: str, inputs: MistakeInputs, rng: np.random.Generator | int | None = None) -> Mistaken:
    """The mistake ``name`` of :data:`MISTAKES` made on ``inputs`` (its draws from ``rng``).

    Examples
    --------
    >>> from monovisual3d.sim.scenes import paper_scene
    >>> from monovisual3d.sim.simulate import simulate
    >>> session, _ = simulate(paper_scene(), rng=0)
    >>> m = make_mistake("views-twice", MistakeInputs(session.to_dict()))
    >>> len(m.session["views"]), m.words
    (6, ('duplicate',))
    """
    if name not in MISTAKES:
        raise InputError(f"mistake: got {name!r}, expected one of {list(MISTAKES)}")
    mistake = MISTAKES[name]
    if not applies(mistake, inputs):
        raise InputError(f"mistake {name!r}: needs {', '.join(sorted(mistake.needs))}, which these inputs do not have")
    return mistake.make(inputs, np.random.default_rng(rng))
