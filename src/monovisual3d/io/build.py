"""Build a validated session from a camera, camera poses and per-image detections.

:func:`build_session` works on objects already read; :func:`import_session`
reads the files first (the ``monovisual3d import`` command). Both return an
:class:`~monovisual3d.io.summary.ImportResult`: the session, validated by the
same loader as session files, and a summary of what was skipped and why.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..camera import Camera
from ..checks import as_float
from ..errors import InputError, InputWarning, excerpt
from ..frames import T_base_optical_from_T_base_cameralink
from ..session import Workspace
from ..session.diagnose import check_session
from ..session.load import POSE_FRAMES, session_from_dict, workspace_from_dict
from ._parse import image_key
from .calibration import read_calibration
from .detections import ImageDetections, _detection_format, filter_detections, read_detections
from .poses import (
    POSITION_UNITS,
    PoseTrajectory,
    T_base_camera_from_T_base_ee,
    interpolate_poses,
    read_hand_eye,
    read_poses,
)
from .summary import ImportResult, ImportSummary

MATCH_MODES = ("auto", "name", "stamp", "order")
#: Default largest time between a detection and the pose samples used for it, seconds.
DEFAULT_MAX_GAP = 0.1
#: Pixel boxes of a source that states no image size, all inside this fraction of the calibration's width
#: and height (from the top-left corner), are taken to be in pixels of smaller images: the import stops.
SMALL_BOX_REGION = 0.5


def build_session(
    camera: Camera,
    poses: PoseTrajectory,
    detections: Sequence[ImageDetections],
    *,
    hand_eye: ArrayLike | None = None,
    pose_frame: str = "optical",
    match: str = "auto",
    max_gap: float = DEFAULT_MAX_GAP,
    min_score: float | None = None,
    labels: Iterable[str] | None = None,
    workspace: Workspace | dict[str, Any] | None = None,
    summary: ImportSummary | None = None,
) -> ImportResult:
    """Pair poses with detections and validate the result as a session.

    One unit of thought: the public builder; its documented options make most of its length, the body only checks them and joins poses to detections.

    Parameters
    ----------
    camera : Camera, for the images the detections were made on
    poses : PoseTrajectory, of the camera, or of the end effector when ``hand_eye`` is given
    detections : list of ImageDetections
    hand_eye : array_like, shape (4, 4), or None
        ``T_ee_camera``: eye-in-hand calibration; then ``T_base_camera = T_base_ee @ T_ee_camera``.
    pose_frame : {"optical", "camera_link"}
        The camera frame the poses (or the hand-eye calibration) refer to:
        ``optical`` (z forward, x right, y down) or ROS ``camera_link`` (x forward, y left, z up).
    match : {"auto", "name", "stamp", "order"}
        ``name``: a pose's ``image`` and a detection file share the file name (without folder and suffix);
        every pose becomes a view (no detections when its image has none).
        ``stamp``: each image's stamp is looked up in the trajectory (:func:`interpolate_poses`).
        ``order``: the i-th pose goes with the i-th image (equal counts).
        ``auto``: by name when both sides have names, else by stamp.
    max_gap : float, seconds, for ``stamp`` matching
    min_score, labels : detection filters, see :func:`filter_detections`
    workspace : Workspace or {"min", "max"} or None
    summary : ImportSummary to add to (a new one by default)

    Returns
    -------
    ImportResult
    """
    summary = summary if summary is not None else ImportSummary()
    if pose_frame not in POSE_FRAMES:
        raise InputError(f"--pose-frame (pose_frame): got {excerpt(pose_frame)}, expected one of {list(POSE_FRAMES)}")
    if match not in MATCH_MODES:
        raise InputError(f"--match (match): got {excerpt(match)}, expected one of {list(MATCH_MODES)}")
    max_gap = as_float(max_gap, "--max-gap (max_gap)")
    if not max_gap >= 0:
        raise InputError(f"--max-gap (max_gap): got {max_gap}, expected seconds >= 0")
    pose_source = poses.source or "poses"
    det_source = summary.source or _detections_source(detections)
    if len(poses) == 0:
        raise InputError(f"{pose_source}: no poses")
    frames = filter_detections(detections, min_score=min_score, labels=labels, summary=summary)
    _check_image_sizes(frames, camera)
    if match == "auto":
        match = _auto_match_mode(poses, frames, summary, pose_source, det_source)
    pairs: list[tuple[NDArray[np.float64], ImageDetections]] = []
    if match == "name":
        pairs = _match_by_name(poses, frames, summary, det_source)
    elif match == "stamp":
        pairs = _match_by_stamp(poses, frames, max_gap, summary, det_source)
    else:
        pairs = _match_by_order(poses, frames, summary, pose_source, det_source)
    if not pairs:
        raise InputError("no view left: no pose matches any image (see the skipped items above)")
    T_all = np.stack([T for T, _ in pairs])
    if hand_eye is not None:
        T_all = T_base_camera_from_T_base_ee(T_all, read_hand_eye(hand_eye))
        summary.note("composed T_base_camera = T_base_ee @ T_ee_camera (eye-in-hand)")
    if pose_frame == "camera_link":
        T_all = T_base_optical_from_T_base_cameralink(T_all)
        summary.note("converted camera_link poses to the optical frame")
    return assemble_session(camera, [(T, f) for T, (_, f) in zip(T_all, pairs)], workspace=workspace, summary=summary)


def assemble_session(
    camera: Camera,
    pairs: Sequence[tuple[NDArray[np.float64], ImageDetections]],
    *,
    workspace: Workspace | dict[str, Any] | None = None,
    summary: ImportSummary | None = None,
) -> ImportResult:
    """Validate ``(T_base_optical, detections)`` pairs as a session (the loader's checks and warnings apply, and the
    input checks of :func:`~monovisual3d.session.diagnose.check_session` warn: boxes of another image size, poses in
    another convention, duplicated views).

    Parameters
    ----------
    camera : Camera
    pairs : list of (ndarray (4, 4) ``T_base_optical``, ImageDetections)
    workspace : Workspace or {"min", "max"} or None
    summary : ImportSummary to fill in

    Returns
    -------
    ImportResult
    """
    summary = summary if summary is not None else ImportSummary()
    if not pairs:
        raise InputError("no view left to build a session from (see the skipped items)")
    views = []
    for T, frame in pairs:
        _check_boxes_in_image(frame, camera)
        view: dict[str, Any] = {"pose": {"matrix": np.asarray(T).tolist()}, "detections": [d.to_dict() for d in frame.detections]}
        if frame.image is not None:
            view["image"] = frame.image
        if frame.stamp is not None:
            view["stamp"] = float(frame.stamp)
        views.append(view)
    data: dict[str, Any] = {"camera": camera.to_dict(), "pose_frame": "optical", "views": views}
    if workspace is not None:
        ws = workspace_from_dict(workspace, "workspace") if isinstance(workspace, dict) else workspace
        data["workspace"] = ws.to_dict()
    try:
        session = session_from_dict(data, None)
    except InputError as exc:
        raise InputError(_input_where(str(exc), [f for _, f in pairs])) from None
    for cause in check_session(session)[1]:  # said now, not only when the session is localised
        warnings.warn(InputWarning(cause.message), stacklevel=2)
    summary.count_session(session)
    return ImportResult(session, summary)


_VIEW_FIELD = re.compile(r"^views\[(\d+)\](?:\.detections\[(\d+)\])?\.?")


def _input_where(message: str, frames: Sequence[ImageDetections]) -> str:
    """A session check's error (``views[0].detections[2].mask.polygon: ...``) told in the user's words:
    the detection file and line it came from (``labels/a.txt: line 3: mask.polygon: ...``), else the image."""
    m = _VIEW_FIELD.match(message)
    if m is None or int(m.group(1)) >= len(frames):
        return message
    frame = frames[int(m.group(1))]
    rest = message[m.end() :].lstrip(": ").strip()
    j = m.group(2)
    if j is not None and int(j) < len(frame.lines):
        return f"{frame.lines[int(j)]}: {rest}"
    what = f"image {frame.name}" + (f", detection {int(j) + 1}" if j is not None else "")
    return f"{frame.source or 'detections'}: {what}: {rest}"


def _detections_source(frames: Sequence[ImageDetections]) -> str:
    """The file(s) detections were read from, for messages."""
    sources = sorted({f.source for f in frames if f.source})
    if not sources:
        return "given"
    return sources[0] if len(sources) == 1 else f"{sources[0]} (and {len(sources) - 1} more files)"


def _frames_have_names_stamps(frames: Sequence[ImageDetections]) -> tuple[bool, bool]:
    return bool(frames) and all(f.image is not None for f in frames), bool(frames) and all(f.stamp is not None for f in frames)


def _what_names(names: bool, stamps: bool) -> str:
    return {
        (True, True): "image names and stamps",
        (True, False): "image names, no stamps",
        (False, True): "stamps, no image names",
        (False, False): "neither image names nor stamps",
    }[(names, stamps)]


def _auto_match_mode(
    poses: PoseTrajectory, frames: Sequence[ImageDetections], summary: ImportSummary, pose_source: str, det_source: str
) -> str:
    """``match="auto"``: ``"name"`` when both sides name their images, else ``"stamp"`` when both have stamps."""
    if poses.images is not None and frames and all(f.image is not None for f in frames):
        match = "name"
    elif poses.stamps is not None and frames and all(f.stamp is not None for f in frames):
        match = "stamp"
    else:
        raise InputError(
            f"cannot match the poses ({pose_source}: {_what_names(poses.images is not None, poses.stamps is not None)}) "
            f"to the detections ({det_source}: {_what_names(*_frames_have_names_stamps(frames))}): "
            "name or stamp matching needs them on both sides; to pair in order, pass --match order (match='order')"
        )
    summary.note(f"matched poses to detections by {'file name' if match == 'name' else 'time stamp'}")
    return match


def _match_by_name(
    poses: PoseTrajectory, frames: Sequence[ImageDetections], summary: ImportSummary, det_source: str
) -> list[tuple[NDArray[np.float64], ImageDetections]]:
    if poses.images is None:
        raise InputError(
            f"{poses.source or 'poses'}: --match name (match='name'): the poses do not name their images "
            "(add an 'image' column, or pass --match stamp or --match order)"
        )
    by_key: dict[str, ImageDetections] = {}
    for f in frames:
        if f.image is None:
            raise InputError(
                f"{f.source or det_source}: --match name (match='name'): the detections of {f.name} have no image name"
            )
        key = image_key(f.image)
        if key in by_key:
            raise InputError(f"{det_source}: two detection sets for image {excerpt(key)} ({by_key[key].source}, {f.source})")
        by_key[key] = f
    pairs = []
    used = set()
    for i, (T, name) in enumerate(zip(poses.T_base_frame, poses.images)):
        key = image_key(name)
        f = by_key.get(key)
        stamp = float(poses.stamps[i]) if poses.stamps is not None else None
        if f is None:
            f = ImageDetections(image=name, stamp=stamp)
        else:
            used.add(key)
            f = ImageDetections(
                image=name,
                stamp=f.stamp if f.stamp is not None else stamp,
                detections=f.detections,
                source=f.source,
                lines=f.lines,
            )
        pairs.append((T, f))
    if by_key and not used:  # every view would be empty: a session that says nothing
        raise InputError(
            f"{det_source}: no detection image matches an image named in {poses.source or 'the poses'} "
            f"(e.g. {excerpt(next(iter(by_key)))} vs {excerpt(image_key(poses.images[0]))}); check the names, or pass --match stamp or --match order"
        )
    for key, f in by_key.items():
        if key not in used:
            summary.skip("image", f.name, "no pose for this image", f"{len(f.detections)} detections")
    return pairs


def _match_by_stamp(
    poses: PoseTrajectory, frames: Sequence[ImageDetections], max_gap: float, summary: ImportSummary, det_source: str
) -> list[tuple[NDArray[np.float64], ImageDetections]]:
    if poses.stamps is None:
        raise InputError(
            f"{poses.source or 'poses'}: --match stamp (match='stamp'): the poses have no time stamps "
            "(pass --match name or --match order)"
        )
    missing = [f for f in frames if f.stamp is None]
    if missing:
        raise InputError(
            f"{missing[0].source or det_source}: --match stamp (match='stamp'): image {missing[0].name} has no stamp "
            "(name the files by time, add a stamp column, or pass --match name or --match order)"
        )
    ordered = sorted(frames, key=lambda f: float(f.stamp))  # type: ignore[arg-type]
    T, ok, why = interpolate_poses(poses.stamps, poses.T_base_frame, [f.stamp for f in ordered], max_gap)
    pairs = []
    for i, f in enumerate(ordered):
        if ok[i]:
            pairs.append((T[i], f))
        else:
            summary.skip("view", f.name, f"no pose within max_gap {max_gap:g} s", str(why[i]))
    return pairs


def _match_by_order(
    poses: PoseTrajectory, frames: Sequence[ImageDetections], summary: ImportSummary, pose_source: str, det_source: str
) -> list[tuple[NDArray[np.float64], ImageDetections]]:
    """``match="order"``: the i-th pose with the i-th image (equal counts)."""
    T_frame = poses.T_base_frame
    if len(poses) != len(frames):
        raise InputError(
            f"{pose_source}: --match order (match='order'): {len(poses)} poses but {len(frames)} images in the "
            f"detections ({det_source}); pairing in order needs one pose per image"
        )
    pairs = [(T_frame[i], f) for i, f in enumerate(frames)]
    last = f", ..., pose {len(frames) - 1} with {frames[-1].name}" if len(frames) > 1 else ""
    summary.note(f"paired poses and images in order (--match order): pose 0 with {frames[0].name}{last}")
    return pairs


def _check_image_sizes(frames: Sequence[ImageDetections], camera: Camera) -> None:
    for f in frames:
        if f.image_size is not None and tuple(f.image_size) != camera.size:
            w, h = f.image_size
            raise InputError(
                f"{f.source or 'detections'}: image {f.name} is {w}x{h} but the calibration is {camera.width}x{camera.height}: "
                f"pass --image-size {w}x{h} (image_size=({w}, {h})) so the intrinsics are scaled to the detector's images"
            )


def check_box_extent(frames: Sequence[ImageDetections], camera: Camera, source: str = "detections") -> None:
    """Stop when pixel boxes that state no image size all lie in a small corner of the camera's image.

    Boxes in pixels of images smaller than the calibration's (a detector run on
    640x480 images against a 4056x3040 calibration) all fall inside the top-left
    part of the calibration image. When every box of the frames without an
    ``image_size`` lies within :data:`SMALL_BOX_REGION` of the width and the
    height, the boxes are taken to refer to other images and an InputError asks
    for their size (``--image-size WxH``); boxes that really are in calibration
    pixels are accepted by stating the calibration's own size.

    Parameters
    ----------
    frames : list of ImageDetections
    camera : Camera, as it will be used (after any ``image_size``/``crop_xyxy``)
    source : str, the detections' file for the message

    Raises
    ------
    InputError
        Naming the file, the extent of the boxes and the option ``--image-size``.

    Examples
    --------
    >>> from monovisual3d.session import Detection
    >>> f = ImageDetections("a.png", detections=(Detection(np.array([300.0, 200, 340, 250])),))
    >>> check_box_extent([f], Camera(640, 480, 500.0, 500.0, 320.0, 240.0))  # fine: the box reaches x = 340 of 640
    """
    boxes = [np.asarray(d.bbox_xyxy, dtype=float) for f in frames if f.image_size is None for d in f.detections]
    if not boxes:
        return
    b = np.stack(boxes)
    x_max, y_max = float(b[:, 2].max()), float(b[:, 3].max())
    W, H = camera.size
    if x_max <= SMALL_BOX_REGION * W and y_max <= SMALL_BOX_REGION * H:
        raise InputError(
            f"{source}: all {len(b)} boxes lie within x <= {x_max:.0f}, y <= {y_max:.0f} px, the top-left corner of the "
            f"{W}x{H} calibration image: they look like pixels of smaller images; state the detector's image size with "
            f"--image-size WxH (image_size=(w, h)), or --image-size {W}x{H} if the boxes really are in calibration pixels"
        )


def _check_boxes_in_image(frame: ImageDetections, camera: Camera) -> None:
    W, H = camera.size
    for j, d in enumerate(frame.detections):
        x1, y1, x2, y2 = (float(v) for v in d.bbox_xyxy)
        if x2 <= 0 or y2 <= 0 or x1 >= W or y1 >= H:
            raise InputError(
                f"{frame.source or 'detections'}: image {frame.name}, detection {j}: box {[x1, y1, x2, y2]} lies outside "
                f"the {W}x{H} image; do the boxes refer to another image size? pass it with --image-size WxH "
                "(image_size=(w, h))"
            )


# ---------------------------------------------------------------------- from files
def _import_camera(
    camera: str | Path | Camera | dict[str, Any],
    camera_format: str | None,
    camera_name: str | int | None,
    image_size: tuple[int, int] | None,
    resize: str,
    crop_xyxy: ArrayLike | None,
) -> Camera:
    """The camera of :func:`import_session`: read from a file or dict, or a Camera scaled to ``image_size``."""
    if isinstance(camera, Camera):
        cam = camera
        if image_size is not None:
            from .image_size import camera_for_image_size

            cam = camera_for_image_size(cam, image_size, resize)
    else:
        cam = read_calibration(
            camera, format=camera_format, camera_name=camera_name, image_size=image_size, resize=resize, crop_xyxy=crop_xyxy
        )
    return cam


def _import_detections(
    detections: str | Path | Sequence[ImageDetections],
    cam: Camera,
    detections_format: str | None,
    class_names: Any,
    coco_images: str | Path | None,
    image_size: tuple[int, int] | None,
    crop_xyxy: ArrayLike | None,
) -> tuple[list[ImageDetections], str, str | None]:
    """The detections of :func:`import_session`, their source for messages and the note on YOLO scaling (or None).

    Pixel boxes of an unstated image size are checked with :func:`check_box_extent` unless ``image_size`` is given.
    """
    size_note = None
    pixel_boxes = True  # boxes in pixels of an unstated image size (CSV, COCO without sizes): see check_box_extent
    if isinstance(detections, (str, Path)):
        det_source = str(detections)
        fmt = detections_format.lower() if detections_format else _detection_format(Path(detections))
        frames = read_detections(detections, format=fmt, image_size=cam.size, class_names=class_names, images=coco_images)
        if fmt == "yolo":
            pixel_boxes = False
            if image_size is not None:
                given = "the size given by --image-size"
            elif crop_xyxy is not None:
                given = "the size of the --crop region"
            else:
                given = "the calibration's image size (right for resized whole images; cropped ones need --crop)"
            size_note = f"YOLO boxes are normalised: scaled to {cam.width}x{cam.height} pixels, {given}"
    else:
        frames = list(detections)
        det_source = _detections_source(frames)
    if image_size is None and pixel_boxes:
        check_box_extent(frames, cam, det_source)
    return frames, det_source, size_note


def _import_summary(
    camera: str | Path | Camera | dict[str, Any], traj: PoseTrajectory, det_source: str, size_note: str | None
) -> ImportSummary:
    """The summary :func:`import_session` starts with: where the camera, poses and detections came from."""
    summary = ImportSummary(source="" if det_source == "given" else det_source)
    cam_source = str(camera) if not isinstance(camera, (Camera, dict)) else "given"
    summary.note(f"camera: {cam_source}; poses: {traj.source or 'given'}; detections: {det_source}")
    if size_note is not None:
        summary.note(size_note)
    return summary


def import_session(
    camera: str | Path | Camera | dict[str, Any],
    poses: str | Path | PoseTrajectory,
    detections: str | Path | Sequence[ImageDetections],
    *,
    hand_eye: str | Path | ArrayLike | dict[str, Any] | None = None,
    camera_format: str | None = None,
    camera_name: str | int | None = None,
    image_size: tuple[int, int] | None = None,
    resize: str = "auto",
    crop_xyxy: ArrayLike | None = None,
    pose_format: str | None = None,
    units: str = "m",
    hand_eye_units: str = "m",
    pose_frame: str = "optical",
    detections_format: str | None = None,
    class_names: Any = None,
    coco_images: str | Path | None = None,
    labels: Iterable[str] | None = None,
    min_score: float | None = None,
    match: str = "auto",
    max_gap: float = DEFAULT_MAX_GAP,
    workspace: Workspace | dict[str, Any] | None = None,
    time_offset: float | str = 0.0,
) -> ImportResult:
    """Read a calibration, poses and detections from files and build a validated session.

    One unit of thought: the public importer; its documented options (one per input format) make most of its length, the body reads each input and calls :func:`build_session`.

    Parameters
    ----------
    camera : calibration file (see :func:`~monovisual3d.io.read_calibration`) or a Camera
    poses : pose file (TUM, CSV, JSON; see :func:`~monovisual3d.io.read_poses`) or a PoseTrajectory
    detections : YOLO label folder/file, COCO JSON or CSV, or a list of ImageDetections
    hand_eye : ``T_ee_camera`` file or matrix; the poses are then end-effector poses
    camera_format, camera_name, image_size, resize, crop_xyxy : see :func:`~monovisual3d.io.read_calibration`
    pose_format, units : see :func:`~monovisual3d.io.read_poses`
    hand_eye_units : {"m", "mm", "cm"}, the unit of the hand-eye translation
    pose_frame, match, max_gap, min_score, labels, workspace : see :func:`build_session`
    detections_format, class_names : see :func:`~monovisual3d.io.read_detections`
    coco_images : the COCO file with the ``images`` list, when ``detections`` is a bare COCO results list
    time_offset : float, seconds, or ``"auto"``: how far the pose stream's clock runs ahead of the images' (each
        image's pose is looked up at its stamp minus it); ``"auto"`` estimates it from the boxes
        (:func:`~monovisual3d.io.time_offset.estimate_time_offset`; not applied where the views cannot tell it) and
        says it in the summary's notes. Needs stamps on the poses and the images.

    Notes
    -----
    The boxes must be in pixels of the camera as used: the calibration's, or
    ``image_size`` (``--image-size``) when the detector saw other images. YOLO's
    normalised boxes are scaled to that size (said in the summary's notes).
    Pixel boxes whose source states no image size (CSV; COCO without ``width``/
    ``height``) are checked with :func:`check_box_extent` when ``image_size`` is
    not given: boxes all in a small corner of the calibration image stop the
    import. Sources that state their size (COCO, Ultralytics results) must match
    the camera.

    Returns
    -------
    ImportResult

    Examples
    --------
    >>> r = import_session("calib.yaml", "poses.csv", "labels/")  # doctest: +SKIP
    >>> r.session.to_json("session.json"); print("\\n".join(r.summary.lines()))  # doctest: +SKIP
    """
    cam = _import_camera(camera, camera_format, camera_name, image_size, resize, crop_xyxy)
    traj = poses if isinstance(poses, PoseTrajectory) else read_poses(poses, format=pose_format, units=units)
    frames, det_source, size_note = _import_detections(
        detections, cam, detections_format, class_names, coco_images, image_size, crop_xyxy
    )
    T_ee_camera = None
    if hand_eye is not None:
        if hand_eye_units not in POSITION_UNITS:
            raise InputError(
                f"--hand-eye-units (hand_eye_units): got {excerpt(hand_eye_units)}, expected one of {list(POSITION_UNITS)}"
            )
        T_ee_camera = read_hand_eye(hand_eye, units=hand_eye_units)
    summary = _import_summary(camera, traj, det_source, size_note)
    traj = _offset_poses(cam, traj, frames, time_offset, T_ee_camera, pose_frame, summary)
    return build_session(
        cam,
        traj,
        frames,
        hand_eye=T_ee_camera,
        pose_frame=pose_frame,
        match=match,
        max_gap=max_gap,
        min_score=min_score,
        labels=labels,
        workspace=workspace,
        summary=summary,
    )


def _offset_poses(
    camera: Camera,
    traj: PoseTrajectory,
    frames: Sequence[ImageDetections],
    time_offset: float | str,
    T_ee_camera: NDArray[np.float64] | None,
    pose_frame: str,
    summary: ImportSummary,
) -> PoseTrajectory:
    """The pose stream with the time offset (seconds, or ``"auto"``: estimated) undone, said in the summary."""
    from .time_offset import estimate_time_offset, shifted

    if isinstance(time_offset, str):
        if time_offset != "auto":
            raise InputError(f"--time-offset (time_offset): got {excerpt(time_offset)}, expected seconds or 'auto'")

        def to_optical(T: NDArray[np.float64]) -> NDArray[np.float64]:
            if T_ee_camera is not None:
                T = T_base_camera_from_T_base_ee(T, T_ee_camera)
            return T_base_optical_from_T_base_cameralink(T) if pose_frame == "camera_link" else T

        est = estimate_time_offset(camera, traj, frames, to_optical)
        summary.note(est.note)
        summary.time_offset = {"offset_s": est.offset_s, "determined": est.determined, "frame_s": est.frame_s}
        offset = est.offset_s
    else:
        offset = as_float(time_offset, "--time-offset (time_offset)")
        if offset:
            summary.note(f"poses looked up at the image stamps minus the time offset {offset:+.4f} s")
    return shifted(traj, offset) if offset else traj


__all__ = [
    "DEFAULT_MAX_GAP",
    "MATCH_MODES",
    "SMALL_BOX_REGION",
    "assemble_session",
    "build_session",
    "check_box_extent",
    "import_session",
]
