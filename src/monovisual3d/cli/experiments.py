"""``demo`` and ``reproduce``: the simulated showcase and the paper's experiments."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..methods import DEFAULT_METHOD, METHODS
from ._app import app, console, handle_errors, plain
from .options import SpreadScheduler, SpreadWorkers, spread_flags


@app.command()
@handle_errors
def demo(
    output: Annotated[Path, typer.Option("--output", "-o", help="Directory for the demo's files.")] = Path("mv3d-demo"),
    seed: Annotated[int, typer.Option(help="Seed of the simulated scene and of the detector noise.")] = 0,
    method: Annotated[str, typer.Option(help=f"Localisation method: {', '.join(sorted(METHODS))}.")] = DEFAULT_METHOD,
) -> None:
    """Try the library without a robot: simulate a tomato truss, localise the fruit and compare with the truth.

    A greenhouse truss (5-10 tomatoes, leaves hiding parts of them) is seen by a
    simulated 640x480 camera from the paper's three poses, with the paper's
    detector noise (5 % box noise, 2 % missed detections). The fruit are
    localised from the boxes alone and compared with the true positions.
    """
    from ..experiments.demo import check_demo_options, compare_with_readme, run_demo
    from .core import print_metrics, print_objects

    check_demo_options(output, seed=seed, method=method)  # before the intro: a bad option prints only the error
    # soft_wrap: explanatory lines stay whole when stdout is not a terminal (rich would wrap them at 80 columns)
    console.print(
        f"[bold]monovisual3d demo[/] (seed {seed}): simulating a greenhouse tomato truss seen from 3 camera poses, "
        f"then localising the fruit with the '{method}' method from the 2D boxes alone...",
        highlight=False,
        soft_wrap=True,
    )
    with console.status("simulating, localising and evaluating..."):
        d = run_demo(output, seed=seed, method=method)
    n_boxes = [len(v.detections) for v in d.session.views]
    console.print(
        f"Scene: {len(d.scene.fruits)} tomatoes, {sum(1 for o in d.scene.occluders if type(o).__name__ == 'Leaf')} leaves; "
        f"detections per view: {', '.join(map(str, n_boxes))} (noise: {100 * d.noise.box_sigma:g} % box noise, "
        f"{100 * d.noise.drop_probability:g} % missed).",
        highlight=False,
        soft_wrap=True,
    )
    print_objects(d.result, title="Localised fruit")
    print_metrics({d.result.method: d.metrics}, title="Errors vs. truth")
    for w in d.result.warnings:
        console.print(f"[yellow]warning:[/] {plain(w)}", highlight=False)
    for note in d.notes:
        console.print(f"[yellow]note:[/] {plain(note)}", highlight=False)
    console.print(
        f"Found {d.metrics.true_positives} of {d.metrics.n_truth} fruit in {d.seconds['total']:.1f} s (localising "
        f"{d.seconds['localise']:.1f} s; the first run on a machine also compiles the kernels, once); "
        f"{plain(compare_with_readme(d.metrics, seed, d.result.method))}.",
        highlight=False,
    )
    console.print(f"Saved to {output}/:", highlight=False, markup=False, soft_wrap=True)
    descriptions = {
        "session": "what the robot recorded (camera, poses, boxes); re-run with `monovisual3d localize`",
        "truth": "the true fruit; compare with `monovisual3d evaluate result.json truth.json`",
        "result": "the localised fruit",
        "scene": "the simulated scene (fruit, stems, leaves)",
        "figure": "3D, front and top views of the true (green) and estimated (red) fruit and the cameras",
        "scene_html": "interactive 3D view: open in a web browser (works offline)",
    }
    for name, path in d.files.items():
        what = descriptions.get(
            name, "what the camera saw, with the detected boxes numbered as in session.json" if name.startswith("view_") else ""
        )
        console.print(f"  {path}" + (f"  - {what}" if what else ""), highlight=False, markup=False, soft_wrap=True)


@app.command()
@handle_errors
def reproduce(
    output: Annotated[Path, typer.Option("--output", "-o", help="Directory for report.md, results.json and figures.")] = Path(
        "mv3d-reproduce"
    ),
    quick: Annotated[bool, typer.Option("--quick", help="Reduced run (coarse grid, 1 seed, subset) for testing.")] = False,
    seeds: Annotated[int | None, typer.Option(help="Noise seeds of the noisy experiment (default 5; 1 with --quick).")] = None,
    workers: SpreadWorkers = None,
    scheduler: SpreadScheduler = None,
) -> None:
    """Re-run the paper's simulation experiments and write a Markdown report with figures.

    Noise-free and noisy simulations of the paper's six spheres, all orderings of
    its three poses, square vs Gaussian kernel, weighted vs geometric centre,
    plus a ghost study (error as the number of fruit grows) against the bayes method.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from ..errors import InputError
    from ..experiments.reproduce import ReproduceConfig
    from ..experiments.reproduce import reproduce as reproduce_fn

    if seeds is not None and seeds < 1:
        raise InputError(f"--seeds: got {seeds}, expected a positive integer")
    overrides = {} if seeds is None else {"seeds": seeds}
    config = ReproduceConfig.quick_config(**overrides) if quick else ReproduceConfig(**overrides)
    with (
        spread_flags(workers, scheduler),
        Progress(
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            console=console.rich,
            transient=True,
        ) as bar,
    ):
        task = bar.add_task("reproducing", total=None)

        def progress(done: int, total: int, what: str) -> None:
            bar.update(task, completed=done, total=total, description=plain(what))

        result = reproduce_fn(output, config, progress=progress, workers=workers, scheduler=scheduler)
    console.print(f"reproduction finished in {result.seconds:.0f} s; report: {plain(result.report)}", highlight=False)
    for note in result.notes:
        console.print(f"[yellow]note:[/] {plain(note)}", highlight=False)
    for name, path in result.files.items():
        if name != "report":
            console.print(f"  {plain(path)}", highlight=False)
