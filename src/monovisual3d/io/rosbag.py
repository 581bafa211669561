"""ROS bags (extra ``[ros]``): ROS 1 ``.bag`` and ROS 2 (sqlite3, MCAP) via the ``rosbags`` library.

:func:`read_bag` builds a session from

- ``/tf`` and ``/tf_static`` (``tf2_msgs/TFMessage``): the transforms are chained from
  the base frame to the camera frame at each detection's stamp (time-stamped
  edges interpolated, linear + slerp, within ``max_gap``);
- a ``sensor_msgs/CameraInfo`` topic for the intrinsics (or a calibration given directly);
- a ``vision_msgs/Detection2DArray`` topic for the boxes.

The messages are read by :mod:`.ros_messages` (the ROS 1 and ROS 2 vision_msgs layouts); a bag that does not
carry the definitions of these messages gets those of :mod:`.ros_messages`.
No ROS installation is needed.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from .._extras import require
from ..camera import Camera
from ..errors import InputError, InputWarning, excerpt
from ..frames import T_base_optical_from_T_base_cameralink
from ..session import Workspace
from ..session.load import POSE_FRAMES
from .build import DEFAULT_MAX_GAP, assemble_session
from .calibration import read_calibration
from .calibration_ros import camera_from_camera_info
from .detections import ImageDetections, filter_detections, load_class_names
from .image_size import camera_for_image_size
from .ros_messages import (
    TF2_MSGS,
    VISION_MSGS_ROS1,
    VISION_MSGS_ROS2,
    detections_from_array,
    stamp_ns,
    transforms_from_tf_message,
)
from .summary import ImportResult, ImportSummary
from .tf import TransformTree, TransformUnavailable, normalise_frame


def message_types(ros_version: int) -> dict[str, Any]:
    """rosbags type definitions (parse trees) of vision_msgs and tf2_msgs for ROS 1 or ROS 2.

    Register them in a rosbags typestore with ``typestore.register(message_types(2))``
    (together with a store that has std_msgs, geometry_msgs and sensor_msgs).
    """
    typesys = require("rosbags.typesys", "ros")
    defs = dict(VISION_MSGS_ROS1 if ros_version == 1 else VISION_MSGS_ROS2)
    defs.update(TF2_MSGS)
    out: dict[str, Any] = {}
    for name, text in defs.items():
        out.update(typesys.get_types_from_msg(text, name))
    return out


def typestore_for(ros_version: int) -> Any:
    """A rosbags typestore with the standard messages (noetic or humble) plus :func:`message_types`."""
    typesys = require("rosbags.typesys", "ros")
    store = typesys.get_typestore(typesys.Stores.ROS1_NOETIC if ros_version == 1 else typesys.Stores.ROS2_HUMBLE)
    types = message_types(ros_version)
    store.register({k: v for k, v in types.items() if k not in store.fielddefs})
    return store


def _missing_closure(names: Iterable[str], target: Any, source: Any) -> dict[str, Any]:
    """Definitions from ``source`` (a typestore) for ``names`` and their dependencies absent from ``target``."""
    out: dict[str, Any] = {}
    todo = [n for n in names if n not in target.fielddefs]
    while todo:
        name = todo.pop()
        if name in out or name in target.fielddefs or name not in source.fielddefs:
            continue
        out[name] = source.fielddefs[name]
        todo.extend(_referenced_types(source.fielddefs[name]))
    return out


def _referenced_types(node: Any) -> list[str]:
    found: list[str] = []
    if isinstance(node, str):
        if "/msg/" in node:
            found.append(node)
    elif isinstance(node, (tuple, list)):
        for item in node:
            found.extend(_referenced_types(item))
    return found


def _bag_path(path: str | Path) -> Path:
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: bag not found")
    if p.is_file() and p.suffix in (".db3", ".mcap") and (p.parent / "metadata.yaml").exists():
        return p.parent
    if p.is_dir() and not (p / "metadata.yaml").exists():
        raise InputError(f"{p}: a folder without metadata.yaml; expected a ROS 2 bag folder or a ROS 1 .bag file")
    if p.is_file() and p.suffix != ".bag":
        raise InputError(f"{p}: expected a ROS 1 .bag file or a ROS 2 bag folder (with metadata.yaml)")
    return p


def read_bag(
    path: str | Path,
    *,
    base_frame: str,
    camera_frame: str,
    detections_topic: str = "/detections",
    camera_info_topic: str | None = None,
    camera: Camera | str | Path | None = None,
    tf_topics: tuple[str, ...] = ("/tf", "/tf_static"),
    pose_frame: str = "optical",
    max_gap: float = DEFAULT_MAX_GAP,
    min_score: float | None = None,
    labels: Iterable[str] | None = None,
    class_names: Any = None,
    image_size: tuple[int, int] | None = None,
    resize: str = "auto",
    workspace: Workspace | dict[str, Any] | None = None,
) -> ImportResult:
    """Build a session from a ROS 1 or ROS 2 bag.

    One unit of thought: the public bag reader; its documented options (topics, frames, timing) make most of its length, the body checks them and calls the bag's readers.

    Parameters
    ----------
    path : a ROS 1 ``.bag`` file or a ROS 2 bag folder (sqlite3 or MCAP storage)
    base_frame : the robot base frame (e.g. ``base_link``)
    camera_frame : the camera's frame in TF (e.g. ``camera_optical_frame``)
    detections_topic : a ``vision_msgs/Detection2DArray`` topic
    camera_info_topic : a ``sensor_msgs/CameraInfo`` topic; found automatically when the bag has exactly one
    camera : a Camera or calibration file to use instead of camera_info
    tf_topics : topics with ``tf2_msgs/TFMessage``; those named ``*tf_static`` are static
    pose_frame : {"optical", "camera_link"}, the convention of ``camera_frame``
    max_gap : float, seconds: largest time between a detection and the TF samples used for it
    min_score, labels : detection filters
    class_names : id -> name map for numeric class ids
    image_size, resize : when the detections refer to a resized image (see :func:`camera_for_image_size`)
    workspace : optional workspace of the session

    Returns
    -------
    ImportResult
        The session (one view per Detection2DArray message whose camera pose is
        known) and a summary of what was skipped and why.

    Examples
    --------
    >>> r = read_bag("run.bag", base_frame="base_link", camera_frame="camera_optical_frame")  # doctest: +SKIP
    >>> r.session.to_json("session.json")  # doctest: +SKIP
    """
    reader_class = _any_reader_class()
    if pose_frame not in POSE_FRAMES:
        raise InputError(f"pose_frame: got {excerpt(pose_frame)}, expected one of {list(POSE_FRAMES)}")
    bag = _bag_path(path)
    summary, names, reader = _open_bag(reader_class, bag, class_names)
    try:
        return _read_open_bag(
            reader,
            bag,
            summary,
            base_frame=normalise_frame(base_frame),
            camera_frame=normalise_frame(camera_frame),
            detections_topic=detections_topic,
            camera_info_topic=camera_info_topic,
            camera=camera,
            tf_topics=tf_topics,
            pose_frame=pose_frame,
            max_gap=max_gap,
            min_score=min_score,
            labels=labels,
            names=names,
            image_size=image_size,
            resize=resize,
            workspace=workspace,
        )
    except InputError as exc:  # name the bag in every message
        name = str(bag)
        raise (exc if str(exc).startswith(name) else InputError(f"{name}: {exc}")) from None
    except Exception as exc:  # corrupt data found while reading (truncated chunks, bad lengths...)
        raise InputError(f"{bag}: cannot read the bag ({type(exc).__name__}: {_one_line(exc)})") from None
    finally:
        _close_quietly(reader)


def _any_reader_class() -> Any:
    """rosbags' ``AnyReader`` (ImportError naming the ``[ros]`` extra without rosbags)."""
    require("rosbags", "ros")
    from rosbags.highlevel import AnyReader

    return AnyReader


def _open_bag(reader_class: Any, bag: Path, class_names: Any) -> tuple[ImportSummary, dict[int, str] | None, Any]:
    """The bag's import summary, the class names, and the bag opened with ``reader_class`` (InputError if unreadable)."""
    summary = ImportSummary(source=str(bag))
    names = load_class_names(class_names) if class_names is not None else None
    try:
        reader = reader_class([bag], default_typestore=typestore_for(2))
        reader.open()
    except InputError:
        raise
    except Exception as exc:  # rosbags raises its own errors, OSError, ValueError... for unreadable bags
        raise InputError(f"{bag}: cannot open the bag: {_one_line(exc)}") from None
    return summary, names, reader


def _close_quietly(reader: Any) -> None:
    """Close the reader; an error while closing a corrupt bag is dropped."""
    try:
        reader.close()
    except Exception:  # closing the reader of a corrupt bag must not hide the error above
        pass


def _read_transforms(reader: Any, bag: Path, tf_topics: tuple[str, ...], t0: int) -> TransformTree:
    """All transforms of the bag's ``tf_topics`` (``*tf_static`` ones static), stamped in seconds since ``t0`` (ns)."""
    tree = TransformTree()
    tf_conns = [c for c in reader.connections if c.topic in tf_topics and c.msgtype.lower().endswith("tfmessage")]
    if not tf_conns:
        raise InputError(f"{bag}: no transforms: none of the topics {list(tf_topics)} is in the bag")
    for conn, ns, raw in reader.messages(connections=tf_conns):
        msg = _deserialize(reader, raw, conn, ns)
        static = conn.topic.rstrip("/").endswith("tf_static")
        for parent, child, T, stamp_ns_ in transforms_from_tf_message(msg, f"{bag}: {conn.topic} at {ns * 1e-9:.9f} s"):
            tree.add(parent, child, T, stamp=None if static else (stamp_ns_ - t0) * 1e-9)
    return tree


def _read_detection_frames(
    reader: Any, bag: Path, det_topic: str, t0: int, names: dict[int, str] | None, summary: ImportSummary
) -> tuple[list[tuple[ImageDetections, float]], set[str], int]:
    """The Detection2DArray messages of ``det_topic``.

    Returns
    -------
    frames : list of (ImageDetections, float seconds since ``t0``), one per message
    frame_ids : set of str, the normalised header frames of the messages
    unstamped : int, messages without a header stamp (their record time is used)
    """
    frames: list[tuple[ImageDetections, float]] = []
    det_conns = [c for c in reader.connections if c.topic == det_topic]
    frame_ids: set[str] = set()
    unstamped = 0
    for conn, ns, raw in reader.messages(connections=det_conns):
        msg = _deserialize(reader, raw, conn, ns)
        msg_ns = stamp_ns(msg.header.stamp)
        if msg_ns == 0:
            msg_ns = ns
            unstamped += 1
        if msg.header.frame_id:
            frame_ids.add(normalise_frame(msg.header.frame_id))
        stamp = msg_ns * 1e-9
        dets, skipped = detections_from_array(msg, names)
        for j, problem in skipped:
            summary.skip("detection", f"stamp {stamp:.6f} #{j}", problem)
        frames.append(
            (
                ImageDetections(image=None, stamp=stamp, detections=tuple(dets), source=f"{bag}:{det_topic}"),
                (msg_ns - t0) * 1e-9,
            )
        )
    return frames, frame_ids, unstamped


def _read_open_bag(reader: Any, bag: Path, summary: ImportSummary, **kw: Any) -> ImportResult:
    ros_version = 2 if reader.is2 else 1
    topics: dict[str, str] = {}
    for c in reader.connections:
        topics.setdefault(c.topic, c.msgtype)
    det_topic = kw["detections_topic"]
    det_types = sorted(t for t, m in topics.items() if m.endswith("/Detection2DArray"))
    if det_topic not in topics:
        raise InputError(f"{bag}: no topic {excerpt(det_topic)}; Detection2DArray topics in the bag: {det_types or 'none'}")
    if not topics[det_topic].endswith("/Detection2DArray"):
        raise InputError(f"{bag}: topic {excerpt(det_topic)} carries {topics[det_topic]}, expected vision_msgs/Detection2DArray")
    _ensure_types(
        reader,
        ros_version,
        [topics[det_topic]] + [m for m in topics.values() if m.endswith(("TFMessage", "tfMessage", "CameraInfo"))],
    )
    t0 = int(reader.start_time) if reader.connections else 0

    # transforms ---------------------------------------------------------------
    tree = _read_transforms(reader, bag, kw["tf_topics"], t0)
    tree.check_connected(kw["base_frame"], kw["camera_frame"])

    # camera -------------------------------------------------------------------
    camera = _bag_camera(reader, bag, topics, summary, kw["camera"], kw["camera_info_topic"])
    if kw["image_size"] is not None:
        camera = camera_for_image_size(camera, kw["image_size"], kw["resize"])

    # detections ---------------------------------------------------------------
    frames, frame_ids, unstamped = _read_detection_frames(reader, bag, det_topic, t0, kw["names"], summary)
    if not frames:
        raise InputError(f"{bag}: topic {excerpt(det_topic)} has no messages")
    if unstamped:
        summary.note(f"{unstamped} detection messages had no header stamp; used the time they were recorded")
    other = sorted(frame_ids - {kw["camera_frame"]})
    if other:
        warnings.warn(
            InputWarning(
                f"{bag}: detections are in frame {excerpt(other[0])} but camera_frame is {excerpt(kw['camera_frame'])}; using camera_frame"
            ),
            stacklevel=3,
        )
    filtered = filter_detections([f for f, _ in frames], min_score=kw["min_score"], labels=kw["labels"], summary=summary)

    # poses --------------------------------------------------------------------
    pairs = []
    max_gap = kw["max_gap"]
    for f, (_, rel) in zip(filtered, frames):
        try:
            T = tree.lookup(kw["base_frame"], kw["camera_frame"], rel, max_gap)
        except TransformUnavailable as exc:
            summary.skip("view", f.name, f"transform not available within max_gap {max_gap:g} s", str(exc))
            continue
        if kw["pose_frame"] == "camera_link":
            T = T_base_optical_from_T_base_cameralink(T)
        pairs.append((T, f))
    summary.note(f"poses from TF: {kw['base_frame']} -> {kw['camera_frame']} ({kw['pose_frame']} frame)")
    return assemble_session(camera, pairs, workspace=kw["workspace"], summary=summary)


def _ensure_types(reader: Any, ros_version: int, msgtypes: list[str]) -> None:
    """Register the definitions of ``msgtypes`` (and dependencies) that the bag does not carry."""
    missing = [m for m in msgtypes if m not in reader.typestore.fielddefs]
    if not missing:
        return
    store = typestore_for(ros_version)
    unknown = [m for m in missing if m not in store.fielddefs]
    if unknown:
        raise InputError(f"the bag has no definition of {unknown[0]} and none is built in")
    reader.typestore.register(_missing_closure(missing, reader.typestore, store))


def _deserialize(reader: Any, raw: bytes, conn: Any, ns: int) -> Any:
    try:
        return reader.deserialize(raw, conn.msgtype)
    except Exception as exc:  # malformed data or a definition that does not match the bytes
        raise InputError(
            f"{conn.topic} at {ns * 1e-9:.9f} s: cannot decode {conn.msgtype} ({type(exc).__name__}: {_one_line(exc, 60)}); "
            "another vision_msgs version?"
        ) from None


def _one_line(exc: BaseException, limit: int = 120) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _bag_camera(reader: Any, bag: Path, topics: dict[str, str], summary: ImportSummary, camera: Any, topic: str | None) -> Camera:
    if camera is not None:
        cam = camera if isinstance(camera, Camera) else read_calibration(camera)
        summary.note("camera from the given calibration (camera_info not used)")
        return cam
    info_topics = sorted(t for t, m in topics.items() if m.endswith("/CameraInfo"))
    if topic is None:
        if len(info_topics) != 1:
            raise InputError(
                f"{bag}: {'no' if not info_topics else 'several'} CameraInfo topics {info_topics}: "
                "give the camera_info topic or a calibration file"
            )
        topic = info_topics[0]
        summary.note(f"camera from {topic}")
    elif topic not in topics:
        raise InputError(f"{bag}: no topic {excerpt(topic)}; CameraInfo topics in the bag: {info_topics or 'none'}")
    conns = [c for c in reader.connections if c.topic == topic]
    first = None
    changed = False
    for conn, ns, raw in reader.messages(connections=conns):
        msg = _deserialize(reader, raw, conn, ns)
        try:
            cam = camera_from_camera_info(msg)
        except InputError as exc:
            raise InputError(f"{bag}: {topic} at {ns * 1e-9:.9f} s: {exc}") from None
        if first is None:
            first = cam
        elif cam != first:
            changed = True
    if first is None:
        raise InputError(f"{bag}: topic {excerpt(topic)} has no messages")
    if changed:
        warnings.warn(InputWarning(f"{bag}: {topic} changes during the recording; using its first message"), stacklevel=4)
    return first


__all__ = ["message_types", "read_bag", "typestore_for"]
