"""``localize`` and ``evaluate``."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from ..errors import InputError, InputWarning
from ..methods import DEFAULT_METHOD, METHODS
from ._app import app, check_output, command_budget, console, handle_errors, json_text, write_output
from .options import TimeLimit, method_config, translate_error, with_method_options

if TYPE_CHECKING:
    from ..metrics import Metrics
    from ..result import Result


def print_objects(result: Result, title: str = "Localised objects") -> None:
    """A readable table of the objects (positions in millimetres, base frame)."""
    table = Table(title=f"{title} ({result.method}, base frame)")
    for col in ("#", "x (mm)", "y (mm)", "z (mm)", "radius (mm)", "score"):
        table.add_column(col, justify="right")
    for i, o in enumerate(result.objects):
        x, y, z = (1000 * o.position).tolist()
        radius = f"{1000 * o.radius:.1f}" if o.radius is not None else "-"
        table.add_row(str(i), f"{x:.1f}", f"{y:.1f}", f"{z:.1f}", radius, f"{o.score:.3g}")
    console.print(table)


def print_metrics(rows: dict[str, Metrics], title: str = "Evaluation") -> None:
    """Metric table, one column per configuration (millimetres and percent)."""
    table = Table(title=title)
    table.add_column("metric")
    for name in rows:
        table.add_column(name, justify="right")

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


@app.command()
@handle_errors
@with_method_options
def localize(
    session: Annotated[Path, typer.Argument(help="Session file (JSON or YAML).")],
    method: Annotated[str, typer.Option(help=f"Method: {', '.join(METHODS)}.")] = DEFAULT_METHOD,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the result JSON here.")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No table or progress bar.")] = False,
    view: Annotated[Path | None, typer.Option("--view", help="Also write an interactive 3D view (HTML, offline) here.")] = None,
    time_limit: TimeLimit = None,
    *,
    method_options: dict[str, Any],
) -> None:
    """Localise the objects of a session and print/write them.

    Every option after --time-limit is a field of a method's config; its help says which method it applies to.
    """
    # validate the options, the files and the outputs before the progress bar, so an error prints alone
    config = method_config(method, method_options)
    check_output(output, session)
    if view is not None:
        check_output(view, session)
    with command_budget(time_limit):
        _localize_and_write(session, config, output, quiet, view)


def _localize_and_write(session: Path, config: Any, output: Path | None, quiet: bool, view: Path | None) -> None:
    """The body of ``localize`` after its checks: load, localise, write and print."""
    from rich.progress import Progress

    from ..api import localize as localize_fn
    from ..session import geometry_warnings, load_session

    loaded = load_session(session)
    for message in geometry_warnings(loaded, single_view=True):
        if message.startswith("views: a single view"):  # load_session warned about the others
            warnings.warn(InputWarning(f"{loaded.source}: {message}"), stacklevel=1)
    try:
        if quiet:
            result = localize_fn(loaded, config=config)
        else:
            with Progress(console=console, transient=True) as bar:
                task = bar.add_task("filtering views", total=None)

                def progress(done: int, total: int) -> None:
                    bar.update(task, completed=done, total=total)

                result = localize_fn(loaded, config=config, progress=progress)
    except InputError as exc:
        raise translate_error(exc, session) from None
    text = json_text(result.to_dict())
    if output is not None:
        write_output(output, text + "\n")
    if view is not None:
        from ..viz3d import write_scene_html

        write_scene_html(loaded, result, path=view)
    if not quiet:
        print_objects(result)
        console.print(f"total {result.timing_s.get('total', float('nan')):.3f} s" + (f"; wrote {output}" if output else ""))
    elif output is None:
        print(text)


@app.command()
@handle_errors
def evaluate(
    estimates: Annotated[Path, typer.Argument(help="Result JSON written by `localize --output`.")],
    truth: Annotated[Path, typer.Argument(help='Truth JSON: {"objects": [{"position": [x, y, z], "radius": r}]}.')],
    gate: Annotated[
        float | None, typer.Option(help="Match gate in metres for recall/precision (default: true radius, >= 20 mm).")
    ] = None,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the metrics JSON here.")] = None,
) -> None:
    """Compare estimates with ground truth: Euclidean error, MAE, MSE, RMSE, MAPE, recall, precision."""
    if gate is not None and not gate > 0:
        raise InputError(f"--gate: got {gate}, expected a positive distance in metres")
    if not math.isfinite(gate if gate is not None else 0.0):
        raise InputError(f"--gate: got {gate}, expected a finite distance in metres")
    check_output(output, estimates, truth)
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
