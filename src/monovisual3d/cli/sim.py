"""``simulate``: write a simulated session (bounding-box camera) with its ground truth."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from .. import limits
from ..errors import InputError, one_line
from ._app import app, command_budget, console, handle_errors, plain
from .options import MaxMemory, TimeLimit


@app.command()
@handle_errors
def simulate(
    output: Annotated[Path, typer.Option("--output", "-o", help="Directory for session.json, truth.json, scene.json, images.")],
    scene: Annotated[
        str, typer.Option(help="paper, greenhouse, random, peppers, cucumbers, apples, mixed, or a scene JSON file.")
    ] = "paper",
    n_fruit: Annotated[
        int | None,
        typer.Option(help="Fruit in greenhouse (default 5-10), random and shape scenes (default 6; cucumbers 4)."),
    ] = None,
    views: Annotated[str, typer.Option(help="paper, ring:N[:DEG], hemisphere:N[:DEG], or a pose file (.json/.yaml).")] = "paper",
    distance: Annotated[float, typer.Option(help="Camera distance to the scene's target, metres.")] = 0.5,
    noise: Annotated[float, typer.Option(help="Box noise std as a fraction of the box size (paper: 0.05).")] = 0.0,
    drop: Annotated[float, typer.Option(help="Probability of missing a detection (paper: 0.02).")] = 0.0,
    false_positives: Annotated[float, typer.Option(help="Expected false-positive boxes per image.")] = 0.0,
    pose_error_mm: Annotated[float, typer.Option(help="Std of the reported camera position error per axis, mm.")] = 0.0,
    pose_error_deg: Annotated[float, typer.Option(help="Std of the reported camera rotation error per axis, degrees.")] = 0.0,
    hfov_deg: Annotated[float, typer.Option(help="Horizontal field of view of the 640x480 camera, degrees.")] = 69.0,
    supersample: Annotated[int, typer.Option(help="Sub-pixel rays per pixel and axis (box accuracy 1/N px).")] = 1,
    images: Annotated[bool, typer.Option("--images/--no-images", help="Write a PNG of each view.")] = True,
    seed: Annotated[int, typer.Option(help="Random seed (scene generation and noise).")] = 0,
    active: Annotated[
        int | None, typer.Option(help="Choose N views with the next-best-view loop (cap:60 candidates) instead of --views.")
    ] = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Simulate the bounding-box camera on a scene and write session + ground truth.

    The paper's noiseless experiment is the default; add ``--noise 0.05 --drop 0.02``
    for its noisy one.
    """
    import numpy as np

    from ..camera import Camera
    from ..figures.views import write_view_picture
    from ..sim.noise import NoiseModel
    from ..sim.scene import Scene
    from ..sim.scenes import SHAPE_SCENES, scene_by_name, scene_target
    from ..sim.simulate import write_simulation
    from ..sim.viewpoints import poses_by_name

    noise_model = NoiseModel.from_mm_deg(
        box_sigma=noise,
        drop_probability=drop,
        false_positive_rate=false_positives,
        pose_error_mm=pose_error_mm,
        pose_error_deg=pose_error_deg,
    )
    _check_counts(n_fruit, seed, active)
    _check_out_dir(output, Path(scene), Path(views))
    rng = np.random.default_rng(seed)
    try:
        camera = Camera.from_hfov(640, 480, hfov_deg)
    except InputError:
        raise InputError(f"--hfov-deg: got {hfov_deg!r}, expected degrees in (0, 180)") from None
    scene_path = Path(scene)
    if scene_path.suffix.lower() in (".json", ".yaml", ".yml"):
        if n_fruit is not None:
            raise InputError("--n-fruit: only for the generated scenes (greenhouse, random, shape scenes), not a scene file")
        sc = Scene.load(scene_path)
    else:
        options = {"camera": camera} if scene in ("greenhouse", *SHAPE_SCENES) else {}
        sc = scene_by_name(scene, rng, n_fruit=n_fruit, **options)
    if active is not None:
        from ..active.loop import write_active_simulation

        with command_budget(time_limit, max_memory):
            paths = write_active_simulation(output, sc, camera, active, noise=noise_model, rng=rng)
        console.print(
            f"active loop: {active} views of {len(sc.fruits)} fruit ({plain(sc.name)}); "
            f"wrote {plain(', '.join(p.name for p in paths.values()))} to {plain(output)}",
            highlight=False,
        )
        return
    poses = poses_by_name(views, scene_target(sc), distance=distance)
    with command_budget(time_limit, max_memory):
        paths = write_simulation(
            output,
            sc,
            camera,
            poses,
            noise=noise_model,
            rng=rng,
            supersample=supersample,
            images=images,
            picture=write_view_picture,
        )
    console.print(
        f"simulated {len(sc.fruits)} fruit ({plain(sc.name)}) from {len(poses)} views; "
        f"wrote {plain(', '.join(p.name for p in paths.values()))} to {plain(output)}",
        highlight=False,
    )


def _check_counts(n_fruit: int | None, seed: int, active: int | None) -> None:
    """Refuse counts beyond :mod:`monovisual3d.limits` before any work (one line naming the option)."""
    if n_fruit is not None and not 1 <= n_fruit <= limits.MAX_SIM_FRUIT:
        raise InputError(f"--n-fruit: got {n_fruit}, expected a positive integer of at most {limits.MAX_SIM_FRUIT}")
    if not 0 <= seed <= limits.MAX_SEED:
        raise InputError(f"--seed: got {seed}, expected an integer in [0, {limits.MAX_SEED}]")
    if active is not None and not 1 <= active <= limits.MAX_ACTIVE_VIEWS:
        raise InputError(f"--active: got {active}, expected a positive number of views of at most {limits.MAX_ACTIVE_VIEWS}")


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
