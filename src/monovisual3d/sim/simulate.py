"""Simulated sessions: ray-cast a scene from camera poses, add noise, write the files.

:func:`simulate` returns a :class:`~monovisual3d.session.Session` (what a robot
would record: reported poses and detector boxes) and a truth dictionary (the
scene's fruit in the ``monovisual3d evaluate`` format, plus per-view details:
true pose, exact visible boxes, which fruit each detection came from).
:func:`write_simulation` writes ``session.json``, ``truth.json``, ``scene.json``
and, optionally, one PNG per view of what the camera saw.

Order of the random draws (fixed, so a seed reproduces a run exactly): for
each view in order, the reported pose, then the missed detections, the box
noise and the false positives of that view; last, the session's hand-eye
error, where the noise model has one. Views taken as frames along a path
(:class:`~.motion.FrameTimes`, a pose stream with a time offset) draw nothing
more: their reported poses start from the stream's pose instead of the true one.
"""

from __future__ import annotations

import json
import struct
import warnings
import zlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import limits
from ..camera import Camera
from ..checks import is_int
from ..errors import InputError
from ..session import Detection, Session, View, Workspace
from ..session.load import load_session
from .motion import FrameTimes, write_import_files
from .noise import NoiseModel
from .raycast import BACKGROUND, OCCLUDER, Rendering, render
from .scene import Scene
from .scenes import default_camera, scene_target
from .viewpoints import check_poses, paper_poses

#: Label of simulated detections.
DETECTION_LABEL = "tomato"
#: Colours of the view pictures (RGB): boxes in blue, which stands out on red fruit, green leaves and the grey
#: background; false positives in magenta; the detection index in white on a tag of the box's colour.
BOX_COLOUR = (0, 70, 255)
FALSE_POSITIVE_COLOUR = (230, 0, 230)
TAG_TEXT_COLOUR = (255, 255, 255)
#: Box line width in pixels of the camera image (times ``supersample`` in the picture).
BOX_LINE_PX = 2
#: 3x5 bitmaps of the digits 0-9 (rows top to bottom, 3 bits each), for the detection index.
_DIGITS = (
    (7, 5, 5, 5, 7),
    (2, 6, 2, 2, 7),
    (7, 1, 7, 4, 7),
    (7, 1, 7, 1, 7),
    (5, 5, 7, 1, 1),
    (7, 4, 7, 1, 7),
    (7, 4, 7, 5, 7),
    (7, 1, 2, 2, 2),
    (7, 5, 7, 5, 7),
    (7, 5, 7, 1, 7),
)


@dataclass(frozen=True)
class SimulatedView:
    """One simulated view with everything the simulator knows about it.

    Attributes
    ----------
    T_base_optical_true : ndarray, shape (4, 4), the pose the image was rendered from
    T_base_optical_reported : ndarray, shape (4, 4), the pose written to the session
    rendering : Rendering, the label image and exact visible boxes
    boxes_xyxy : ndarray, shape (K, 4), pixels, the reported (noisy) detections
    source : ndarray, shape (K,), int64, fruit index of each detection, -1 for a false positive
    E_hand_eye : ndarray, shape (4, 4), or None, the session's hand-eye error, part of the reported pose
        (``T_base_optical_reported = T_base_optical_true @ pose error @ E_hand_eye``); None without one
    """

    T_base_optical_true: NDArray[np.float64]
    T_base_optical_reported: NDArray[np.float64]
    rendering: Rendering
    boxes_xyxy: NDArray[np.float64]
    source: NDArray[np.int64]
    E_hand_eye: NDArray[np.float64] | None = None


def simulate_views(
    scene: Scene,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    *,
    noise: NoiseModel | None = None,
    rng: np.random.Generator | int | None = None,
    supersample: int = 1,
    min_pixels: float = 1.0,
    E_hand_eye: NDArray[np.float64] | None = None,
    frames: FrameTimes | None = None,
) -> list[SimulatedView]:
    """Render every pose and apply the noise model; the building block of :func:`simulate`.

    Parameters are those of :func:`simulate`, and ``E_hand_eye`` (4, 4): the session's hand-eye error where its views
    are simulated in parts (the next-best-view loop); None: drawn here from ``noise`` (after every other draw, so a
    session with one has the same boxes as without).

    Returns
    -------
    list of SimulatedView, one per pose
    """
    if not isinstance(scene, Scene):
        raise InputError(f"scene: expected a Scene, got {type(scene).__name__}")
    camera = camera or default_camera()
    P = paper_poses(scene_target(scene)) if poses is None else check_poses(poses)
    noise = noise or NoiseModel()
    if not isinstance(noise, NoiseModel):
        raise InputError(f"noise: expected a NoiseModel, got {type(noise).__name__}")
    check_sim_work(len(P), camera, supersample)
    streamed = _streamed_poses(frames, len(P))
    rng = np.random.default_rng(rng)
    out = []
    for T_true, T_stream in zip(P, streamed if streamed is not None else P):
        rendering = render(scene, camera, T_true, supersample=supersample, min_pixels=min_pixels)
        T_reported = noise.apply_to_pose(T_stream, rng)
        visible = np.flatnonzero(rendering.visible)
        boxes, source = noise.apply_to_boxes(rendering.boxes_xyxy[visible], camera.size, rng)
        fruit = np.full(len(source), -1, dtype=np.int64)
        fruit[source >= 0] = visible[source[source >= 0]]
        out.append(SimulatedView(T_true, T_reported, rendering, boxes, fruit))
    E = noise.hand_eye_error(rng) if E_hand_eye is None else E_hand_eye  # one per session; None without one
    return out if E is None else [replace(sv, T_base_optical_reported=sv.T_base_optical_reported @ E, E_hand_eye=E) for sv in out]


def simulate(
    scene: Scene,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    *,
    noise: NoiseModel | None = None,
    rng: np.random.Generator | int | None = None,
    supersample: int = 1,
    min_pixels: float = 1.0,
    workspace: Workspace | None = None,
    frames: FrameTimes | None = None,
) -> tuple[Session, dict[str, Any]]:
    """Simulate a session: the bounding-box camera at each pose, with optional noise.

    Parameters
    ----------
    scene : Scene
    camera : Camera, default 640 x 480 pixels, 69 degrees horizontal field of view
    poses : array_like, shape (N, 4, 4), true ``T_base_optical`` of each view;
        default the paper's three poses around the scene's target
    noise : NoiseModel, default none (exact boxes, exact poses)
    rng : numpy Generator, seed or None
    supersample : int, sub-pixel rays per pixel and axis (box accuracy 1 / supersample px)
    min_pixels : float, visible area a fruit needs to be detected, pixels
    workspace : Workspace, optional, written to the session
    frames : FrameTimes, optional: the views are frames along a path (:mod:`~monovisual3d.sim.motion`); each view
        gets its image stamp, and its reported pose starts from the pose stream's (late or early by a time offset)

    Returns
    -------
    session : Session
        Reported poses and detections (``label`` "tomato", no score), views in pose order.
    truth : dict
        ``objects`` (fruit positions/radii/labels, the ``evaluate`` format), ``views``
        (per view: ``T_base_optical_true``, ``T_base_optical_reported`` as 4x4 lists,
        ``visible_bbox_xyxy`` exact boxes per fruit with None for hidden fruit,
        ``visible_px`` per fruit, ``detection_fruit`` the fruit index of each
        detection with -1 for false positives), ``hand_eye_error`` (the session's hand-eye error ``E`` as a 4x4
        list, in every view's reported pose, or None), ``noise`` and ``scene``; with ``frames``, ``frames``
        (:meth:`FrameTimes.to_dict`: the time offset, frame rate and image stamps).

    Examples
    --------
    >>> from monovisual3d.sim.scenes import paper_scene
    >>> session, truth = simulate(paper_scene(), rng=0)
    >>> len(session.views), [len(v.detections) for v in session.views], len(truth["objects"])
    (3, [6, 6, 6], 6)
    """
    views = simulate_views(
        scene, camera, poses, noise=noise, rng=rng, supersample=supersample, min_pixels=min_pixels, frames=frames
    )
    camera = camera or default_camera()
    return _session_and_truth(scene, camera, views, noise or NoiseModel(), workspace, images=None, frames=frames)


def write_simulation(
    directory: str | Path,
    scene: Scene,
    camera: Camera | None = None,
    poses: ArrayLike | None = None,
    *,
    noise: NoiseModel | None = None,
    rng: np.random.Generator | int | None = None,
    supersample: int = 1,
    min_pixels: float = 1.0,
    workspace: Workspace | None = None,
    images: bool = True,
    picture: Callable[[Path, SimulatedView, str], None] | None = None,
    frames: FrameTimes | None = None,
) -> dict[str, Path]:
    """:func:`simulate` and write the results to ``directory`` (created if needed).

    Files: ``session.json`` (load with :func:`monovisual3d.load_session`),
    ``truth.json`` (see :func:`simulate`; usable with ``monovisual3d evaluate``),
    ``scene.json`` (:meth:`Scene.load`), and with ``images`` one ``view_NN.png``
    per view: the label image (background grey, occluders green, fruit in shades of red)
    with the reported boxes (:func:`view_image`), or what ``picture(path, view, name)`` draws
    (e.g. :func:`monovisual3d.figures.views.write_view_picture`: boxes numbered by their index
    in the view's detections, titled, with a legend; the simulator does not draw figures itself).
    With ``frames`` (views along a path, :mod:`~monovisual3d.sim.motion`), also ``poses.csv`` (the pose
    stream) and ``detections.csv`` (the boxes with their image stamps), which ``monovisual3d import`` reads.

    Returns
    -------
    dict
        ``{"session": path, "truth": path, "scene": path, "view_00": path, ...}``
    """
    out_dir = Path(directory)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: exists and is not a directory")
    n_poses = 3 if poses is None else len(np.asarray(poses))
    if images and n_poses > limits.MAX_SIM_PICTURES:
        raise InputError(
            f"--views: {n_poses} views with --images, more than the {limits.MAX_SIM_PICTURES} pictures drawn in one run; "
            "give --no-images or fewer views"
        )
    views = simulate_views(
        scene, camera, poses, noise=noise, rng=rng, supersample=supersample, min_pixels=min_pixels, frames=frames
    )
    camera = camera or default_camera()
    names = [f"view_{i:02d}.png" for i in range(len(views))] if images else None
    session, truth = _session_and_truth(scene, camera, views, noise or NoiseModel(), workspace, images=names, frames=frames)
    _check_loads(session, out_dir / "session.json")
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"session": out_dir / "session.json", "truth": out_dir / "truth.json", "scene": out_dir / "scene.json"}
    session.to_json(paths["session"])
    paths["truth"].write_text(json.dumps(truth, indent=2) + "\n")
    scene.save(paths["scene"])
    if frames is not None:
        E = None if truth["hand_eye_error"] is None else np.asarray(truth["hand_eye_error"])
        paths.update(write_import_files(out_dir, session, frames, E))
    paths.update(_write_pictures(out_dir, names or [], views, picture))
    return paths


def _write_pictures(
    out_dir: Path, names: list[str], views: list[SimulatedView], picture: Callable[[Path, SimulatedView, str], None] | None
) -> dict[str, Path]:
    """Write one picture per view (``names``; none when empty): :func:`view_image`, or what ``picture`` draws."""
    paths = {}
    for i, (name, v) in enumerate(zip(names, views)):
        path = out_dir / name
        if picture is None:
            write_png(path, view_image(v))
        else:
            picture(path, v, f"view {i}")
        paths[name.removesuffix(".png")] = path
    return paths


def check_sim_work(n_views: int, camera: Camera | None, supersample: int) -> None:
    """Refuse a simulation beyond :data:`~monovisual3d.limits.MAX_SIM_VIEWS` views or
    :data:`~monovisual3d.limits.MAX_SIM_RAYS` rays, before any ray is cast (one-line :class:`InputError`)."""
    if n_views > limits.MAX_SIM_VIEWS:
        raise InputError(f"--views: {n_views} views, more than the {limits.MAX_SIM_VIEWS} a simulation may have")
    if not is_int(supersample) or supersample < 1:
        return  # the renderer refuses it with its own message
    width, height = (camera or default_camera()).size
    rays = n_views * width * height * int(supersample) ** 2
    if rays > limits.MAX_SIM_RAYS:
        raise InputError(
            f"--supersample (supersample): {n_views} views x {width}x{height} px x {supersample}^2 = {rays:.3g} rays, more than the "
            f"{limits.MAX_SIM_RAYS:.3g} cast in one run; use fewer --views or a lower --supersample"
        )


def _check_loads(session: Session, path: Path) -> None:
    """Refuse to write a session that :func:`monovisual3d.load_session` would refuse (what we write, we can read)."""
    try:
        with warnings.catch_warnings():  # the geometry warnings come when the file is loaded
            warnings.simplefilter("ignore")
            load_session(session.to_dict())
    except InputError as exc:
        raise InputError(f"{path}: the simulated session would not load ({exc}); check --distance and --pose-error-mm") from None


def view_image(view: SimulatedView, *, boxes: bool = True) -> NDArray[np.uint8]:
    """RGB picture of a simulated view: label colours plus the reported boxes, shape (H, W, 3), uint8.

    Background grey, occluders green, fruit in shades of red. Each reported box
    is drawn :data:`BOX_LINE_PX` pixels wide inside its edges, in
    :data:`BOX_COLOUR` (false positives in :data:`FALSE_POSITIVE_COLOUR`), with
    its index in the view's detections (``session.json``'s order) written on a
    tag at its top-left corner (no boxes with ``boxes=False``). The picture has the label
    image's resolution (``supersample`` times the camera's).

    Examples
    --------
    >>> from monovisual3d.sim.scenes import paper_scene
    >>> view_image(simulate_views(paper_scene(), rng=0)[0]).shape
    (480, 640, 3)
    """
    labels = view.rendering.labels
    s = view.rendering.supersample
    img = np.empty(labels.shape + (3,), dtype=np.uint8)
    img[labels == BACKGROUND] = (200, 200, 200)
    img[labels == OCCLUDER] = (40, 140, 40)
    fruit = labels >= 0
    shade = (labels[fruit] * 37) % 100
    img[fruit] = np.stack([220 - shade // 2, 30 + shade, 30 + shade // 2], axis=-1).astype(np.uint8)
    H, W = labels.shape
    if not boxes:
        return img
    t = BOX_LINE_PX * s
    for j, (box, src) in enumerate(zip(view.boxes_xyxy, view.source)):
        colour = BOX_COLOUR if src >= 0 else FALSE_POSITIVE_COLOUR
        x1, y1, x2, y2 = (int(v) for v in np.round(np.asarray(box, dtype=float) * s))
        x1, y1 = max(x1, 0), max(y1, 0)
        x2, y2 = min(x2, W), min(y2, H)  # exclusive ends
        if x2 <= x1 or y2 <= y1:
            continue
        img[y1 : min(y1 + t, y2), x1:x2] = colour
        img[max(y2 - t, y1) : y2, x1:x2] = colour
        img[y1:y2, x1 : min(x1 + t, x2)] = colour
        img[y1:y2, max(x2 - t, x1) : x2] = colour
        _draw_tag(img, str(j), x1, y1, colour, scale=s)
    return img


def _draw_tag(img: NDArray[np.uint8], text: str, x: int, y: int, colour: tuple[int, int, int], scale: int = 1) -> None:
    """Write the digits ``text`` (2x-size 3x5 font, times ``scale``) on a filled tag whose top-left corner is at ``(x, y)``.

    The tag sits on the box's top-left corner, inside the box when there is no room above it; it is clipped to the image.
    """
    k = 2 * scale  # pixels per font dot
    pad = scale
    w = len(text) * 4 * k - k + 2 * pad
    h = 5 * k + 2 * pad
    H, W = img.shape[:2]
    top = y - h if y - h >= 0 else y
    tag = np.empty((h, w, 3), dtype=np.uint8)
    tag[:] = colour
    for i, ch in enumerate(text):
        bits = np.array([[(row >> (2 - c)) & 1 for c in range(3)] for row in _DIGITS[int(ch)]], dtype=bool)
        glyph = np.kron(bits, np.ones((k, k), dtype=bool))
        x0 = pad + i * 4 * k
        tag[pad : pad + 5 * k, x0 : x0 + 3 * k][glyph] = TAG_TEXT_COLOUR
    y_end, x_end = min(top + h, H), min(x + w, W)
    img[top:y_end, x:x_end] = tag[: y_end - top, : x_end - x]


def write_png(path: str | Path, image: NDArray[np.uint8]) -> None:
    """Write an 8-bit grey (H, W) or RGB (H, W, 3) image as PNG (zlib only, no extra dependency)."""
    img = np.ascontiguousarray(image, dtype=np.uint8)
    if img.ndim == 2:
        colour_type = 0
    elif img.ndim == 3 and img.shape[2] == 3:
        colour_type = 2
    else:
        raise InputError(f"image: expected shape (H, W) or (H, W, 3), got {img.shape}")
    H, W = img.shape[:2]
    raw = np.concatenate([np.zeros((H, 1), dtype=np.uint8), img.reshape(H, -1)], axis=1).tobytes()

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", W, H, 8, colour_type, 0, 0, 0)
    Path(path).write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
    )


def _session_and_truth(
    scene: Scene,
    camera: Camera,
    views: list[SimulatedView],
    noise: NoiseModel,
    workspace: Workspace | None,
    images: list[str] | None,
    frames: FrameTimes | None = None,
) -> tuple[Session, dict[str, Any]]:
    session_views = []
    truth_views = []
    for i, v in enumerate(views):
        dets = tuple(Detection(np.asarray(b, dtype=float), None, DETECTION_LABEL) for b in v.boxes_xyxy)
        stamp = None if frames is None else float(frames.stamps[i])
        session_views.append(View(v.T_base_optical_reported, dets, images[i] if images else None, stamp))
        truth_views.append(
            {
                "T_base_optical_true": v.T_base_optical_true.tolist(),
                "T_base_optical_reported": v.T_base_optical_reported.tolist(),
                "visible_bbox_xyxy": [None if not np.isfinite(b[0]) else [float(x) for x in b] for b in v.rendering.boxes_xyxy],
                "visible_px": [float(x) for x in v.rendering.visible_px],
                "detection_fruit": [int(x) for x in v.source],
            }
        )
    session = Session(camera, tuple(session_views), workspace)
    truth = {
        **scene.truth_dict(),
        "views": truth_views,
        "hand_eye_error": None if not views or views[0].E_hand_eye is None else views[0].E_hand_eye.tolist(),
        "noise": noise.to_dict(),
        "scene": scene.to_dict(),
    }
    if frames is not None:
        truth["frames"] = frames.to_dict()
    return session, truth


def _streamed_poses(frames: FrameTimes | None, n_views: int) -> NDArray[np.float64] | None:
    """The pose stream's poses of the views (``frames``), checked against the number of views; None without."""
    if frames is None:
        return None
    if not isinstance(frames, FrameTimes):
        raise InputError(f"frames: expected a FrameTimes, got {type(frames).__name__}")
    T = np.asarray(frames.T_base_optical_reported, dtype=float)
    if T.shape != (n_views, 4, 4) or np.shape(frames.stamps) != (n_views,):
        raise InputError(f"frames: stamps and poses for {len(frames.stamps)} views, expected {n_views} (one per pose)")
    return T
