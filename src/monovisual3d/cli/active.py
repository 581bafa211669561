"""``next-view`` (choose the next camera pose, say when to stop) and ``bench active``."""

from __future__ import annotations

import json
import math
import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._app import app, console, handle_errors
from .bench import bench_app


def _vector3(text: str, option: str) -> tuple[float, float, float]:
    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise InputError(f"{option}: got {text!r}, expected X,Y,Z in metres")
    return v  # type: ignore[return-value]


@app.command("next-view")
@handle_errors
def next_view(
    session: Annotated[Path, typer.Argument(help="Session file (JSON/YAML) with the views so far (may have none).")],
    candidates: Annotated[
        str,
        typer.Option(
            help="Candidate poses: a file {'poses': [{position, quaternion_xyzw}, ...]} in the session's pose_frame, "
            "or cap:N[:distance=LO..HI][:azimuth=LO..HI][:elevation=LO..HI][:reach=R] (metres, degrees)."
        ),
    ],
    count: Annotated[int, typer.Option(help="Views to choose jointly (batch).")] = 1,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the plan JSON here (default: stdout).")] = None,
    target_mm: Annotated[float, typer.Option(help="Stopping rule: largest 95 % semi-axis of every object, mm.")] = 5.0,
    motion_weight: Annotated[float, typer.Option(help="Gain (mm) lost per metre of camera travel.")] = 0.0,
    reach: Annotated[
        float | None, typer.Option(help="Arm reach, metres: candidates farther from --base are never picked.")
    ] = None,
    base: Annotated[str, typer.Option(help="Centre of the reach sphere X,Y,Z, metres, base frame.")] = "0,0,0",
    target: Annotated[
        str | None,
        typer.Option(
            help="Cap centre X,Y,Z (metres); default the workspace centre, else the estimates' mean, else 0.5 m along the first view."
        ),
    ] = None,
    box_noise: Annotated[
        float | None, typer.Option(help="Detector box noise as a fraction of the box size (default: the sensor model's 0.05).")
    ] = None,
) -> None:
    """Choose the next camera pose from candidates by expected gain; report "done" when the estimate is good enough.

    Output: {"index", "pose", "gain", "ranking": [{"index", "gain"}], "done", ...}; with --count K also
    "indices", "poses" and "gains". Indices refer to the candidate list (for cap:N, the poses left
    after the reach filter, listed in "candidates").
    """
    import numpy as np

    from ..active.candidates import CapSpec, cap_poses, load_candidates, pose_to_dict
    from ..active.planner import PlannerConfig, PlannerState, default_workspace, load_planning_session, plan_from_state
    from ..localize import localize
    from ..session import read_structured_file

    if isinstance(count, bool) or count < 1:
        raise InputError(f"--count: got {count}, expected a positive integer")
    raw = read_structured_file(session)
    pose_frame = raw.get("pose_frame", "optical") if isinstance(raw, dict) else "optical"
    sess = load_planning_session(session)
    base_c = _vector3(base, "--base")
    generated = candidates.strip().startswith("cap:")
    # validate the candidates (and --count) before the localisation, which takes the time
    if generated:
        spec = CapSpec.parse(candidates)
        n_max = spec.n
    else:
        cands = load_candidates(candidates, pose_frame)
        n_max = len(cands)
    if count > n_max:
        raise InputError(f"--count: got {count}, expected at most {n_max} (the number of candidates)")
    n_with = sum(1 for v in sess.views if v.detections)
    objects = []
    if n_with >= 2:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            objects = localize(sess).objects
    state = PlannerState(sess.camera, sess.views, tuple(objects), sess.workspace)
    reach_m = reach
    if generated:
        if target is not None:
            centre = np.array(_vector3(target, "--target"))
        else:
            try:
                ws = default_workspace(state)
            except InputError:
                raise InputError(f"{session}: no views and no workspace; give --target X,Y,Z for the cap") from None
            centre = 0.5 * (ws.min + ws.max)
        axis = sess.views[0].T_base_optical[:3, 3] if sess.views else None
        cands = cap_poses(spec, centre, axis=axis, base_centre=base_c)
        if reach_m is None and math.isfinite(spec.reach_m):
            reach_m = spec.reach_m
    if count > len(cands):
        raise InputError(f"--count: got {count}, expected at most {len(cands)} (the number of candidates)")
    if reach_m is not None and not (reach_m > 0 and math.isfinite(reach_m)):
        raise InputError(f"--reach: got {reach_m}, expected a positive number of metres")
    cfg = PlannerConfig(
        target_mm=target_mm, motion_weight=motion_weight, reach_m=reach_m if reach_m is not None else math.inf,
        base_centre=base_c, box_noise=box_noise,
    )  # fmt: skip
    if target is not None and sess.workspace is None:
        c = np.array(_vector3(target, "--target"))
        from ..session import Workspace

        state = PlannerState(sess.camera, sess.views, tuple(objects), Workspace(c - 0.2, c + 0.2))
    try:
        plan = plan_from_state(state, cands, count=count, config=cfg)
    except InputError as exc:
        msg = str(exc)
        if msg.startswith("count:"):
            raise InputError("--" + msg) from None
        raise
    out = plan.to_dict(pose_frame)
    out["n_objects"] = len(objects)
    out["views"] = len(sess.views)
    if generated:
        out["candidates"] = [pose_to_dict(T, pose_frame) for T in cands]
    text = json.dumps(out, indent=2)
    if output is None:
        sys.stdout.write(text + "\n")
    else:
        output.write_text(text + "\n")
        console.print(
            f"next view: candidate {plan.index} (gain {plan.gain:.2f}), done={str(plan.done).lower()}; wrote {output}",
            highlight=False,
        )


@bench_app.command("active")
@handle_errors
def bench_active(
    seeds: Annotated[str, typer.Option(help="Seeds: A..B (inclusive) or a comma-separated list.")] = "0..9",
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
) -> None:
    """Next-best-view against fixed, random and view-sphere viewpoints: error, recall, 95 % ellipsoid vs. views."""
    from rich.progress import Progress

    from ..active.bench import format_markdown, merge_results, run_active_bench, save
    from ..active.bench import plot as plot_results

    if report is not None:
        parts = []
        for name in report.split(","):
            try:
                parts.append(json.loads(Path(name).read_text()))
            except json.JSONDecodeError as exc:
                raise InputError(f"{name}: not a results file ({exc.msg})") from None
        res = merge_results(parts)
    else:
        seed_t = _parse_seeds(seeds)
        conds = tuple(c.strip() for c in conditions.split(",") if c.strip())
        with Progress(console=console, transient=True, disable=not console.is_terminal) as bar:
            task = bar.add_task("active benchmark", total=None)

            def progress(msg: str) -> None:
                bar.update(task, description=msg)
                if not console.is_terminal:
                    console.print(f"done {msg}", highlight=False)

            res = run_active_bench(conditions=conds, seeds=seed_t, max_views=views, n_candidates=candidates, progress=progress)
    command = "monovisual3d bench active " + " ".join(shlex.quote(a) for a in sys.argv[3:]) if len(sys.argv) > 3 else None
    text = format_markdown(res, command)
    print(text)
    if markdown is not None:
        markdown.write_text(text)
    if output is not None:
        save(res, str(output))
        console.print(f"wrote {output}", highlight=False)
    if plot is not None:
        plot_results(res, str(plot))
        console.print(f"wrote {plot}", highlight=False)


def _parse_seeds(text: str) -> tuple[int, ...]:
    try:
        if ".." in text:
            a, b = text.split("..")
            lo, hi = int(a), int(b)
            if hi < lo:
                raise ValueError
            return tuple(range(lo, hi + 1))
        out = tuple(int(x) for x in text.split(","))
        if not out:
            raise ValueError
        return out
    except ValueError:
        raise InputError(f"--seeds: got {text!r}, expected A..B or a comma-separated list of integers") from None
