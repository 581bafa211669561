"""``localize`` and ``evaluate``."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..errors import InputError, InputWarning
from ..methods import DEFAULT_METHOD, METHODS
from ._app import app, check_output, command_budget, console, handle_errors, json_text, plain, print_warning, write_output
from .options import MaxMemory, MethodOptions, TimeLimit, method_config, translate_error, with_method_options
from .panels import PANEL_FIND, PANEL_LIMITS, PANEL_OUTPUT, PanelCommand

if TYPE_CHECKING:
    from ..metrics import Metrics
    from ..result import Result
    from ..session import Session


def print_objects(result: Result, title: str = "Localised objects") -> None:
    """A readable table of the objects (positions in millimetres, base frame); shape columns when any is not a sphere."""
    from rich.table import Table  # on first use: rich is 0.02-0.03 s of a command's start (issue 56)

    table = Table(title=f"{title} ({plain(result.method)}, base frame)")
    shaped = any(o.shape not in (None, "sphere") for o in result.objects)
    columns = ("#", "x (mm)", "y (mm)", "z (mm)", "radius (mm)", *(("shape", "semi-axes (mm)") if shaped else ()), "score")
    for col in columns:
        table.add_column(col, justify="left" if col == "shape" else "right")
    for i, o in enumerate(result.objects):
        x, y, z = (1000 * o.position).tolist()
        radius = f"{1000 * o.radius:.1f}" if o.radius is not None else "-"
        shape = (o.shape or "-", "/".join(f"{1000 * a:.1f}" for a in o.semi_axes) if o.semi_axes is not None else "-")
        table.add_row(str(i), f"{x:.1f}", f"{y:.1f}", f"{z:.1f}", radius, *(shape if shaped else ()), f"{o.score:.3g}")
    console.print(table)


#: What each metric of :func:`print_metrics` means (printed under the table and in ``evaluate --help``; formulas in
#: docs/usage.md and :mod:`monovisual3d.metrics`).
METRIC_NOTE = (
    "Euclidean: 3D distance from each estimate to its matched true object (mean, median, max over objects). "
    "MAE, MSE, RMSE, MAPE: over the x, y and z errors separately (the paper's Eqs. 10-13), so RMSE = "
    "sqrt(mean squared 3D distance / 3) and can be below the Euclidean mean; MAPE divides by the true coordinate. "
    "recall: true objects matched within the gate / true objects; precision: the same matches / estimates."
)


def print_metrics(rows: dict[str, Metrics], title: str = "Evaluation") -> None:
    """Metric table, one column per configuration (millimetres and percent), and the definitions under it."""
    from rich.table import Table

    table = Table(title=title)
    table.add_column("metric")
    for name in rows:
        table.add_column(plain(name), justify="right")

    def fmt(v: float | None, scale: float = 1.0, digits: int = 2) -> str:
        return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v * scale:.{digits}f}"

    spec: list[tuple[str, str, float, int]] = [
        ("Euclidean mean (mm)", "euclidean_mean", 1e3, 2),
        ("Euclidean median (mm)", "euclidean_median", 1e3, 2),
        ("Euclidean max (mm)", "euclidean_max", 1e3, 2),
        ("MAE (mm)", "mae", 1e3, 2),
        ("MSE (mm^2)", "mse", 1e6, 2),
        ("RMSE (mm)", "rmse", 1e3, 2),
        ("MAPE (%)", "mape", 1.0, 2),
        ("radius error (mm)", "radius_error_mean", 1e3, 2),
        *(
            [
                ("semi-axis error (mm)", "semi_axis_error_mean", 1e3, 2),
                ("volume error (cm^3)", "volume_error_mean", 1e6, 2),
                ("volume error (%)", "volume_error_pct_mean", 1.0, 2),
            ]
            if any(m.semi_axis_error_mean is not None for m in rows.values())
            else []
        ),
        ("recall", "recall", 1.0, 3),
        ("precision", "precision", 1.0, 3),
    ]
    for label, key, scale, digits in spec:
        table.add_row(label, *(fmt(getattr(m, key), scale, digits) for m in rows.values()))
    table.add_row("truth / estimates", *(f"{m.n_truth} / {m.n_estimates}" for m in rows.values()))
    table.add_row("misses / false pos.", *(f"{m.misses} / {m.false_positives}" for m in rows.values()))
    console.print(table)
    console.print(f"[dim]{METRIC_NOTE}[/]", highlight=False)


@app.command(cls=PanelCommand)
@handle_errors
@with_method_options
def localize(
    session: Annotated[Path, typer.Argument(help="Session file (JSON or YAML).")],
    method: Annotated[str, typer.Option(help=f"Method: {', '.join(METHODS)}.", rich_help_panel=PANEL_FIND)] = DEFAULT_METHOD,
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Write the result JSON here.", rich_help_panel=PANEL_OUTPUT)
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No table or progress bar.", rich_help_panel=PANEL_OUTPUT)] = False,
    view: Annotated[
        Path | None,
        typer.Option("--view", help="Also write an interactive 3D view (HTML, offline) here.", rich_help_panel=PANEL_OUTPUT),
    ] = None,
    strict: Annotated[
        bool,
        typer.Option(
            "--strict",
            help="Exit 1 (after writing the outputs) when the result's verdict is not ok (a named cause: see its "
            "warning), or two or more views have boxes and the result is empty or leaves boxes associated to no object.",
            rich_help_panel=PANEL_OUTPUT,
        ),
    ] = False,
    time_limit: Annotated[
        float | None,
        typer.Option(
            "--time-limit", help="Stop with an error after this many seconds (default: no limit).", rich_help_panel=PANEL_LIMITS
        ),
    ] = None,
    *,
    method_options: MethodOptions,
) -> None:
    """Localise the objects of a session and print/write them.

    Warnings follow the table, one line each on stderr (also with --quiet), and are kept in the
    result's "warnings". The options shown are those a user decides; every other option of a method
    stays settable: --help-all lists the expert flags (by method) and the developer knobs, which
    --set NAME=VALUE reaches; `monovisual3d options METHOD` is the table of them all.
    """
    # validate the options, the files and the outputs before the progress bar, so an error prints alone
    config = method_config(method, method_options)
    check_output(output, session)
    if view is not None:
        check_output(view, session, flag="--view")
    with command_budget(time_limit):
        _localize_and_write(session, config, output, quiet, view, strict)


def _localize_and_write(session: Path, config: Any, output: Path | None, quiet: bool, view: Path | None, strict: bool) -> None:
    """The body of ``localize`` after its checks: load, localise, write and print; ``strict``: exit 1 if incomplete."""
    from ..completeness import incomplete_reasons, merge_reasons, strict_failure
    from ..session.baseline import geometry_warnings
    from ..session.load import load_session

    loaded = load_session(session)
    for message in geometry_warnings(loaded, single_view=True):
        if message.startswith("views: a single view"):  # load_session warned about the others
            warnings.warn(InputWarning(f"{loaded.source}: {message}"), stacklevel=1)
    try:
        result = _run_localize(loaded, config, quiet)
    except InputError as exc:
        raise translate_error(exc, session) from None
    reasons = incomplete_reasons(loaded, result)  # empty, or boxes left unexplained: one line each, with the reason
    shown = merge_reasons(result.warnings, reasons)
    result.warnings.extend(r for r in reasons if not any(w in r for w in result.warnings))  # the JSON keeps its own
    text = json_text(result.to_dict())
    if output is not None:
        write_output(output, text + "\n")
    if view is not None:
        from ..figures.html3d import write_scene_html

        write_scene_html(loaded, result, path=view)
    if not quiet:
        print_objects(result)
        console.print(
            f"total {result.timing_s.get('total', float('nan')):.3f} s" + (f"; wrote {plain(output)}" if output else "")
        )
        calibration = result.quality.get("calibration") or {}
        if calibration.get("applied"):
            console.print(calibration["note"], highlight=False)
        if result.quality.get("edge_noise"):
            console.print(result.quality["edge_noise"]["note"], highlight=False)
    elif output is None:
        print(text)
    for line in shown:
        print_warning(line)
    if strict and strict_failure(reasons, result):
        raise typer.Exit(1)


def _run_localize(session: Session, config: Any, quiet: bool) -> Result:
    """Run the method (with a transient progress bar unless ``quiet``); its warnings are kept for after the table."""
    from ..api import localize as localize_fn

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        if quiet:
            result = localize_fn(session, config=config)
        else:
            from rich.progress import Progress

            with Progress(console=console.rich, transient=True) as bar:
                task = bar.add_task("filtering views", total=None)

                def progress(done: int, total: int) -> None:
                    bar.update(task, completed=done, total=total)

                result = localize_fn(session, config=config, progress=progress)
    for w in caught:  # the result's own warnings print after the table; others (e.g. from numba) now
        if str(w.message) not in result.warnings:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    return result


EVALUATE_HELP = (
    "Compare estimates with ground truth: Euclidean error, MAE, MSE, RMSE, MAPE, recall, precision.\n\n"
    + METRIC_NOTE
    + " Estimates and truth are paired by minimum total distance (Hungarian). Formulas: docs/usage.md."
)


@app.command(help=EVALUATE_HELP)
@handle_errors
def evaluate(
    estimates: Annotated[Path, typer.Argument(help="Result JSON written by `localize --output`.")],
    truth: Annotated[Path, typer.Argument(help='Truth JSON: {"objects": [{"position": [x, y, z], "radius": r}]}.')],
    gate: Annotated[
        float | None, typer.Option(help="Match gate in metres for recall/precision (default: true radius, >= 20 mm).")
    ] = None,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the metrics JSON here.")] = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Compare estimates with ground truth (help: :data:`EVALUATE_HELP`)."""
    if gate is not None and not gate > 0:
        raise InputError(f"--gate: got {gate}, expected a positive distance in metres")
    if not math.isfinite(gate if gate is not None else 0.0):
        raise InputError(f"--gate: got {gate}, expected a finite distance in metres")
    check_output(output, estimates, truth)
    with command_budget(time_limit, max_memory):
        _evaluate_and_print(estimates, truth, gate, output)


def _evaluate_and_print(estimates: Path, truth: Path, gate: float | None, output: Path | None) -> None:
    """The body of ``evaluate`` after its checks: load both files, match, print and write the metrics."""
    from ..metrics import evaluate as evaluate_fn
    from ..truth import load_objects

    est = load_objects(estimates)
    tru = load_objects(truth, allow_empty=False)
    if tru.from_result and not est.from_result:
        warnings.warn(
            InputWarning(
                f"{truth} is a localize result and {estimates} is not: arguments swapped? "
                "expected `monovisual3d evaluate RESULT TRUTH`; comparing as given"
            ),
            stacklevel=1,
        )
    m = evaluate_fn(
        est.positions,
        tru.positions,
        truth_radii=tru.radii if tru.has_radii else None,
        estimate_radii=est.radii,
        gate=gate,
        truth_semi_axes=tru.semi_axes if tru.has_shapes else None,
        estimate_semi_axes=est.semi_axes,
    )
    print_metrics({str(estimates.name): m})
    if output is not None:
        write_output(Path(output), json_text(m.to_dict()) + "\n")
