"""``simulate``: write a simulated session (bounding-box camera) with its ground truth."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Any

import typer

from .. import limits
from ..errors import InputError, one_line
from ._app import app, command_budget, console, handle_errors, plain
from .options import MaxMemory, TimeLimit

#: ``--scene``: a named scene or a scene file.
SceneOption = Annotated[
    str, typer.Option(help="paper, greenhouse, random, row, peppers, cucumbers, apples, mixed, or a scene JSON file.")
]

#: ``--n-fruit``: fruit of a generated scene.
NFruitOption = Annotated[
    int | None,
    typer.Option(help="Fruit in greenhouse (default 5-10), random and shape scenes (default 6; cucumbers 4), row (48)."),
]

#: ``--views``: named poses or a pose file.
ViewsOption = Annotated[
    str,
    typer.Option(
        help="paper, ring:N[:DEG], hemisphere:N[:DEG], arc:N[:DEG] (around the scene), row:N (along the row), or a pose file."
    ),
]

#: ``--time-offset``: the pose stream runs this far ahead of the images (views along an arc or a row).
TimeOffsetOption = Annotated[
    float | None,
    typer.Option(
        help="Views are frames along --views arc:N or row:N, the reported poses those at image time + SECONDS "
        "(1/frame-rate: one frame late); also writes poses.csv and detections.csv for `import`."
    ),
]

#: ``--frame-rate``: the rate of the frames along the path.
FrameRateOption = Annotated[float, typer.Option(help="Frames per second of the views along the path (with --time-offset).")]

#: ``--distance``: camera distance to the scene, metres.
DistanceOption = Annotated[
    float | None, typer.Option(help="Camera distance to the scene's target, metres (default 0.5; row scene 0.8).")
]

#: ``--row-length``: length of the row, metres.
RowLengthOption = Annotated[float | None, typer.Option(help="Length of the row scene and of row:N views, metres (default 1.2).")]

#: ``--image-size``: WIDTHxHEIGHT, pixels.
ImageSizeOption = Annotated[
    str | None, typer.Option(help="Image size WIDTHxHEIGHT in pixels (default 640x480; row scene 1280x720).")
]

#: ``--active``: views chosen by the next-best-view loop.
ActiveOption = Annotated[
    int | None, typer.Option(help="Choose N views with the next-best-view loop (cap:60 candidates) instead of --views.")
]


@app.command()
@handle_errors
def simulate(
    output: Annotated[Path, typer.Option("--output", "-o", help="Directory for session.json, truth.json, scene.json, images.")],
    scene: SceneOption = "paper",
    n_fruit: NFruitOption = None,
    views: ViewsOption = "paper",
    distance: DistanceOption = None,
    row_length: RowLengthOption = None,
    noise: Annotated[float, typer.Option(help="Box noise std as a fraction of the box size (paper: 0.05).")] = 0.0,
    drop: Annotated[float, typer.Option(help="Probability of missing a detection (paper: 0.02).")] = 0.0,
    false_positives: Annotated[float, typer.Option(help="Expected false-positive boxes per image.")] = 0.0,
    pose_error_mm: Annotated[float, typer.Option(help="Std of the reported camera position error per axis, mm.")] = 0.0,
    pose_error_deg: Annotated[float, typer.Option(help="Std of the reported camera rotation error per axis, degrees.")] = 0.0,
    hand_eye_error_mm: Annotated[
        float, typer.Option(help="Std per camera axis, mm, of one hand-eye calibration error shared by every view.")
    ] = 0.0,
    hand_eye_error_deg: Annotated[
        float, typer.Option(help="Std per camera axis, degrees, of one hand-eye calibration error shared by every view.")
    ] = 0.0,
    hfov_deg: Annotated[float | None, typer.Option(help="Horizontal field of view, degrees (default 69; row scene 90).")] = None,
    image_size: ImageSizeOption = None,
    supersample: Annotated[int, typer.Option(help="Sub-pixel rays per pixel and axis (box accuracy 1/N px).")] = 1,
    images: Annotated[bool, typer.Option("--images/--no-images", help="Write a PNG of each view.")] = True,
    seed: Annotated[int, typer.Option(help="Random seed (scene generation and noise).")] = 0,
    time_offset: TimeOffsetOption = None,
    frame_rate: FrameRateOption = 5.0,
    active: ActiveOption = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Simulate the bounding-box camera on a scene and write session + ground truth.

    The paper's noiseless experiment is the default; add '--noise 0.05 --drop 0.02' for its noisy one.
    """
    import numpy as np

    from ..sim.noise import NoiseModel

    noise_model = NoiseModel.from_mm_deg(
        box_sigma=noise,
        drop_probability=drop,
        false_positive_rate=false_positives,
        pose_error_mm=pose_error_mm,
        pose_error_deg=pose_error_deg,
        hand_eye_error_mm=hand_eye_error_mm,
        hand_eye_error_deg=hand_eye_error_deg,
    )
    _check_counts(n_fruit, seed, active)
    _check_time_offset(views, time_offset, frame_rate, active)
    _check_out_dir(output, Path(scene), Path(views))
    rng = np.random.default_rng(seed)
    is_row = scene == "row"
    distance, length = _row_geometry(is_row, views, distance, row_length)
    camera = _camera(image_size, hfov_deg, is_row)
    sc = _scene(scene, n_fruit, rng, camera, length)
    with command_budget(time_limit, max_memory):
        if active is not None:
            _write_active(output, sc, camera, active, noise_model, rng)
            return
        poses, frames = _poses(views, sc, distance, length, time_offset, frame_rate)
        _write_views(output, sc, camera, poses, noise_model, rng, supersample, images, frames)


def _poses(views: str, sc: Any, distance: float, length: float, time_offset: float | None, rate: float) -> tuple[Any, Any]:
    """The poses of ``--views`` around the scene, and with ``--time-offset`` the frames along their path (else None)."""
    from ..sim.motion import frame_times
    from ..sim.scenes import scene_target
    from ..sim.viewpoints import poses_by_name

    target = scene_target(sc)
    poses = poses_by_name(views, target, distance=distance, row_length=length)
    if time_offset is None:
        return poses, None

    def path(at: Any) -> Any:
        return poses_by_name(views, target, distance=distance, row_length=length, at=at)

    return poses, frame_times(path, len(poses), rate, time_offset)


def _write_views(
    output: Path, sc: Any, camera: Any, poses: Any, noise_model: Any, rng: Any, supersample: int, images: bool, frames: Any = None
) -> None:
    """Simulate the views at ``poses`` and write the session, truth, scene and pictures; one line on the terminal."""
    from ..figures.views import write_view_picture
    from ..sim.simulate import write_simulation

    paths = write_simulation(
        output,
        sc,
        camera,
        poses,
        noise=noise_model,
        rng=rng,
        supersample=supersample,
        images=images,
        workspace=_workspace(sc),
        picture=write_view_picture,
        frames=frames,
    )
    console.print(
        f"simulated {len(sc.fruits)} fruit (scene {plain(sc.name)}) from {len(poses)} views; "
        f"wrote {plain(', '.join(p.name for p in paths.values()))} to {plain(output)}",
        highlight=False,
    )


def _row_geometry(is_row: bool, views: str, distance: float | None, row_length: float | None) -> tuple[float, float]:
    """The camera distance and the row length, metres: the options, else the row scene's or the paper's defaults."""
    from ..sim.viewpoints import PAPER_DISTANCE_M, ROW_DISTANCE_M, ROW_LENGTH_M

    if row_length is not None and not (is_row or views.strip().startswith("row:")):
        raise InputError("--row-length: only for --scene row or --views row:N")
    distance = distance if distance is not None else (ROW_DISTANCE_M if is_row else PAPER_DISTANCE_M)
    return distance, ROW_LENGTH_M if row_length is None else row_length


def _check_counts(n_fruit: int | None, seed: int, active: int | None) -> None:
    """Refuse counts beyond :mod:`monovisual3d.limits` before any work (one line naming the option)."""
    if n_fruit is not None and not 1 <= n_fruit <= limits.MAX_SIM_FRUIT:
        raise InputError(f"--n-fruit: got {n_fruit}, expected a positive integer of at most {limits.MAX_SIM_FRUIT}")
    if not 0 <= seed <= limits.MAX_SEED:
        raise InputError(f"--seed: got {seed}, expected an integer in [0, {limits.MAX_SEED}]")
    if active is not None and not 1 <= active <= limits.MAX_ACTIVE_VIEWS:
        raise InputError(f"--active: got {active}, expected a positive number of views of at most {limits.MAX_ACTIVE_VIEWS}")


def _check_time_offset(views: str, time_offset: float | None, frame_rate: float, active: int | None) -> None:
    """Refuse ``--time-offset`` without views along a path, or with ``--active``, and a bad offset or rate, before any work."""
    from ..sim.motion import check_timing
    from ..sim.viewpoints import PATH_VIEWS

    if time_offset is None:
        return
    if active is not None:
        raise InputError("--time-offset: not with --active (the next-best-view loop follows no path)")
    if views.strip().partition(":")[0] not in PATH_VIEWS:
        raise InputError(f"--time-offset: needs views along a path, --views arc:N[:DEG] or row:N; got {views!r}")
    check_timing(time_offset, frame_rate)


#: Files ``simulate`` writes into its output folder (besides the view pictures).
_WRITTEN = ("session.json", "truth.json", "scene.json")


def _check_out_dir(output: Path, *inputs: Path) -> None:
    """The output folder must be a folder we can create or write, and must not hold an input we would overwrite."""
    name = one_line(str(output))
    if output.exists() and not output.is_dir():
        raise InputError(f"{name}: exists and is not a folder, expected the output folder")
    existing = next((p for p in (output, *output.parents) if p.exists()), Path("."))
    if not os.access(existing, os.W_OK):
        raise InputError(f"{name}: cannot write ({one_line(str(existing))} is not writable)")
    for source in inputs:
        for written in _WRITTEN:
            target = output / written
            if source.is_file() and target.exists() and os.path.samefile(source, target):
                raise InputError(
                    f"{one_line(str(target))}: is also an input file; refusing to overwrite it, choose another --output"
                )


def _write_active(output: Path, sc, camera, active: int, noise_model, rng) -> None:  # noqa: ANN001 - sim types imported lazily
    """``--active``: choose the views with the next-best-view loop and write the simulation."""
    from ..active.loop import write_active_simulation

    if active < 1:
        raise InputError(f"--active: got {active}, expected a positive number of views")
    paths = write_active_simulation(output, sc, camera, active, noise=noise_model, rng=rng)
    console.print(
        f"active loop: {active} views of {len(sc.fruits)} fruit (scene {plain(sc.name)}); "
        f"wrote {plain(', '.join(p.name for p in paths.values()))} to {plain(output)}",
        highlight=False,
    )


def _scene(scene: str, n_fruit: int | None, rng, camera, length: float):  # noqa: ANN001, ANN202 - sim types imported lazily
    """The scene of ``--scene``: a scene file, or a generated scene (the row of ``length`` metres)."""
    from ..sim.scene import Scene
    from ..sim.scenes import SHAPE_SCENES, scene_by_name

    if Path(scene).suffix.lower() in (".json", ".yaml", ".yml"):
        if n_fruit is not None:
            raise InputError("--n-fruit: only for the generated scenes (greenhouse, random, row, shape scenes), not a scene file")
        return Scene.load(Path(scene))
    options: dict[str, object] = {"camera": camera} if scene in ("greenhouse", *SHAPE_SCENES) else {}
    if scene == "row":
        options = {"length": length}
    return scene_by_name(scene, rng, n_fruit=n_fruit, **options)


def _camera(image_size: str | None, hfov_deg: float | None, row: bool):  # noqa: ANN202 - Camera imported lazily
    """The simulated camera of ``--image-size`` and ``--hfov-deg`` (defaults: 640x480 at 69 degrees; row: 1280x720 at 90)."""
    from ..camera import Camera
    from ..sim.row import ROW_HFOV_DEG, ROW_IMAGE_SIZE

    width, height = ROW_IMAGE_SIZE if row else (640, 480)
    if image_size is not None:
        w, sep, h = image_size.lower().partition("x")
        if not (sep and w.strip().isdigit() and h.strip().isdigit() and int(w) > 0 and int(h) > 0):
            raise InputError(f"--image-size: got {image_size!r}, expected WIDTHxHEIGHT in pixels, e.g. 1280x720")
        width, height = int(w), int(h)
    hfov = hfov_deg if hfov_deg is not None else (ROW_HFOV_DEG if row else 69.0)
    try:
        return Camera.from_hfov(width, height, hfov)
    except InputError:
        raise InputError(f"--hfov-deg: got {hfov!r}, expected degrees in (0, 180)") from None


def _workspace(scene):  # noqa: ANN001, ANN202 - Scene/Workspace imported lazily
    """The workspace a generated scene states (the row scene's box), else None."""
    import numpy as np

    from ..session import Workspace

    ws = scene.metadata.get("workspace") if isinstance(scene.metadata, dict) else None
    if not isinstance(ws, dict):
        return None
    return Workspace(np.asarray(ws["min"], dtype=float), np.asarray(ws["max"], dtype=float))
