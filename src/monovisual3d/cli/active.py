"""``next-view`` (choose the next camera pose, say when to stop) and ``bench active``."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from .._structured import read_text
from ..errors import InputError
from ._app import app, check_output, command_budget, console, handle_errors, plain, print_warning, write_output
from .bench import bench_app
from .options import MaxMemory, SpreadScheduler, SpreadWorkers, TimeLimit, spread_flags

#: plan_session's parameters named in its errors, and the flags they come from.
_FLAGS = {
    "candidates": "--candidates",
    "count": "--count",
    "reach_m": "--reach",
    "base": "--base",
    "target": "--target",
    "box_noise": "--box-noise",
    "target_mm": "--target-mm",
    "motion_weight": "--motion-weight",
    "tool_frame": "--tool-frame",
}

CandidatesOption = Annotated[
    str,
    typer.Option(
        help="Candidate poses: a file {'poses': [{position, quaternion_xyzw}, ...]} in the session's pose_frame, "
        "or cap:N[:distance=LO..HI][:azimuth=LO..HI][:elevation=LO..HI][:reach=R] (metres, degrees)."
    ),
]
TargetOption = Annotated[
    str | None,
    typer.Option(
        help="Cap centre X,Y,Z (metres); default the workspace centre, else the estimates' mean, else 0.5 m along the first view."
    ),
]
BoxNoiseOption = Annotated[
    str,
    typer.Option(
        help="Detector box noise as a fraction of the box size, or auto: estimated from the boxes seen so far "
        "(at least 0.01; the sensor model's 0.05 until there are enough)."
    ),
]
ToolFrameOption = Annotated[
    str | None,
    typer.Option(
        "--tool-frame",
        help="Name of the arm's tool frame: output the tool's goal pose (camera pose @ inverse hand-eye); needs --hand-eye.",
    ),
]
HandEyeOption = Annotated[
    Path | None,
    typer.Option(
        "--hand-eye",
        help="Hand-eye calibration T_tool_camera, the camera in the tool frame (file, as import --hand-eye), for --tool-frame.",
    ),
]


def _as_flags(message: str) -> str:
    """A library error message with the parameter names turned into this command's flags."""
    name, sep, rest = message.partition(":")
    if sep and name in _FLAGS:
        return _FLAGS[name] + sep + rest
    return message.replace("; give target X,Y,Z", "; give --target X,Y,Z")


@app.command("next-view")
@handle_errors
def next_view(
    session: Annotated[Path, typer.Argument(help="Session file (JSON/YAML) with the views so far (may have none).")],
    candidates: CandidatesOption,
    count: Annotated[int, typer.Option(help="Views to choose jointly (batch).")] = 1,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the plan JSON here (default: stdout).")] = None,
    target_mm: Annotated[float, typer.Option(help="Stopping rule: largest 95 % semi-axis of every object, mm.")] = 5.0,
    motion_weight: Annotated[float, typer.Option(help="Gain (mm) lost per metre of camera travel.")] = 0.0,
    reach: Annotated[
        float | None, typer.Option(help="Arm reach, metres: candidates farther from --base are never picked.")
    ] = None,
    base: Annotated[str, typer.Option(help="Centre of the reach sphere X,Y,Z, metres, base frame.")] = "0,0,0",
    target: TargetOption = None,
    box_noise: BoxNoiseOption = "auto",
    tool_frame: ToolFrameOption = None,
    hand_eye: HandEyeOption = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Choose the next camera pose from candidates by expected gain; report "done" when the estimate is good enough.

    Output: {"index", "pose", "gain", "ranking": [{"index", "gain"}], "done", "warnings", "quality", ...} (the
    warnings and quality of the views so far, as localize gives them); with --count K also
    "indices", "poses" and "gains". Indices refer to the candidate list (for cap:N, the poses left
    after the reach filter, listed in "candidates"). With --tool-frame and --hand-eye, "pose" ("poses") is the
    tool's goal pose and "camera_pose" ("camera_poses") the camera's.
    """
    from ..active.api import plan_session
    from ..io.poses import read_hand_eye

    candidate_file = None if candidates.strip().startswith("cap:") else Path(candidates)
    check_output(output, session, candidate_file, hand_eye)
    if (tool_frame is None) != (hand_eye is None):
        raise InputError("--tool-frame, --hand-eye: give both (the tool frame's name and the camera's pose in it) or neither")
    T_tool_camera = read_hand_eye(hand_eye) if hand_eye is not None else None
    try:
        with command_budget(time_limit, max_memory):
            out = plan_session(
                session,
                candidates,
                count=count,
                target_mm=target_mm,
                motion_weight=motion_weight,
                reach_m=reach,
                base=base,
                target=target,
                box_noise=_box_noise(box_noise),
                tool_frame=tool_frame,
                T_tool_camera=T_tool_camera,
            )
    except InputError as exc:
        raise InputError(_as_flags(str(exc))) from None
    _write_plan(out, output)


def _write_plan(out: dict[str, Any], output: Path | None) -> None:
    """The plan as JSON on stdout, or written to ``output`` with a short summary on the terminal; the localisation's
    warnings one line each on stderr, as ``localize`` prints them."""
    text = json.dumps(out, indent=2)
    if output is None:
        sys.stdout.write(text + "\n")
    else:
        write_output(output, text + "\n")
        _print_plan(out, output)
    for line in out.get("warnings", []):
        print_warning(line)


def _print_plan(out: dict[str, Any], output: Path) -> None:
    """The chosen poses, one row each (candidate index, position, gain in mm), and whether the estimate is good enough."""
    indices = out.get("indices", [out["index"]])
    poses = out.get("poses", [out["pose"]])
    gains = out.get("gains", [out["gain"]])
    table = Table(
        title=f"Next view{'s' if len(indices) > 1 else ''} ({plain(out.get('tool_frame', 'camera'))} position, metres, base frame)",
        caption="gain: expected drop of the objects' RMS position error, mm, summed over the objects (less the motion cost)",
    )
    for col in ("pick", "candidate", "x (m)", "y (m)", "z (m)", "gain (mm)"):
        table.add_column(col, justify="right")
    for pick, (index, pose, gain) in enumerate(zip(indices, poses, gains, strict=True), start=1):
        x, y, z = pose["position"]
        table.add_row(str(pick), str(index), f"{x:.3f}", f"{y:.3f}", f"{z:.3f}", f"{gain:.2f}")
    console.print(table)
    console.print(f"done={str(out['done']).lower()}; wrote {plain(output)}", highlight=False)


@bench_app.command("active")
@handle_errors
def bench_active(
    seeds: Annotated[
        str, typer.Option(help="Seeds: A..B ranges (inclusive) or integers, comma separated, e.g. 0..9,100..109.")
    ] = "0..9",
    conditions: Annotated[str, typer.Option(help="Comma separated: greenhouse-noise, greenhouse, paper-noise.")] = (
        "greenhouse-noise,greenhouse,paper-noise"
    ),
    views: Annotated[int, typer.Option(help="Views per run (the first is fixed).")] = 8,
    candidates: Annotated[int, typer.Option(help="Candidates on the cap.")] = 60,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the results as JSON here.")] = None,
    plot: Annotated[Path | None, typer.Option(help="Write the error-vs-views plot (PNG) here.")] = None,
    markdown: Annotated[Path | None, typer.Option(help="Write the Markdown tables here too.")] = None,
    report: Annotated[
        str | None,
        typer.Option(help="Run nothing: join these results files (comma separated, from --output) into one report and plot."),
    ] = None,
    workers: SpreadWorkers = None,
    scheduler: SpreadScheduler = None,
) -> None:
    """Next-best-view against fixed, random and view-sphere viewpoints: error, recall, 95 % ellipsoid vs. views."""
    reports = [Path(name) for name in report.split(",")] if report is not None else []
    for path, flag in ((output, "--output"), (plot, "--plot"), (markdown, "--markdown")):  # before any work, never over an input
        check_output(path, *reports, flag=flag)
    if report is not None:
        res = _merge_reports(report)
    else:
        res = _run_with_progress(
            _parse_seeds(seeds),
            tuple(c.strip() for c in conditions.split(",") if c.strip()),
            views=views,
            candidates=candidates,
            workers=workers,
            scheduler=scheduler,
        )
    _write_results(res, markdown=markdown, output=output, plot=plot)


def _merge_reports(report: str) -> dict[str, Any]:
    """``--report``: the results files (comma separated, from ``--output``) joined into one result."""
    from ..active.bench import merge_results

    parts = []
    for name in report.split(","):
        try:
            parts.append(json.loads(read_text(name)))
        except json.JSONDecodeError as exc:
            raise InputError(f"{name}: not a results file ({exc.msg})") from None
    return merge_results(parts)


def _run_with_progress(
    seeds: tuple[int, ...],
    conditions: tuple[str, ...],
    *,
    views: int,
    candidates: int,
    workers: int | None,
    scheduler: str | None,
) -> dict[str, Any]:
    """Run the benchmark with a progress bar on a terminal (a ``done ...`` line per run elsewhere)."""
    from rich.progress import Progress

    from ..active.bench import run_active_bench

    with (
        spread_flags(workers, scheduler),
        Progress(console=console.rich, transient=True, disable=not console.is_terminal) as bar,
    ):
        task = bar.add_task("active benchmark", total=None)

        def progress(msg: str) -> None:
            bar.update(task, description=plain(msg))
            if not console.is_terminal:
                console.print(f"done {plain(msg)}", highlight=False)

        return run_active_bench(
            conditions=conditions,
            seeds=seeds,
            max_views=views,
            n_candidates=candidates,
            progress=progress,
            workers=workers,
            scheduler=scheduler,
        )


def _write_results(res: dict[str, Any], *, markdown: Path | None, output: Path | None, plot: Path | None) -> None:
    """Print the Markdown tables (with the command that made them) and write the files asked for."""
    from ..active.bench import format_markdown, save
    from ..active.bench import plot as plot_results

    command = "monovisual3d bench active " + " ".join(shlex.quote(a) for a in sys.argv[3:]) if len(sys.argv) > 3 else None
    text = format_markdown(res, command)
    print(text)
    if markdown is not None:
        write_output(markdown, text)
    if output is not None:
        save(res, str(output))
        console.print(f"wrote {plain(output)}", highlight=False)
    if plot is not None:
        plot_results(res, str(plot))
        console.print(f"wrote {plain(plot)}", highlight=False)


def _box_noise(text: str) -> float | str:
    """``--box-noise``: ``auto`` or a fraction."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        return float(text)
    except ValueError:
        raise InputError(f"--box-noise: got {text!r}, expected a fraction >= 0 or 'auto'") from None


def _parse_seeds(text: str) -> tuple[int, ...]:
    """Seeds from ``A..B`` ranges (inclusive) and integers, comma separated: ``0..9,100..109``, ``1,5,7``."""
    out: list[int] = []
    try:
        for part in text.split(","):
            if ".." in part:
                a, b = part.split("..")
                lo, hi = int(a), int(b)
                if hi < lo:
                    raise ValueError
                out += range(lo, hi + 1)
            else:
                out.append(int(part))
    except ValueError:
        raise InputError(f"--seeds: got {text!r}, expected A..B ranges or integers, comma separated") from None
    return tuple(out)
