"""``bench startup``: start-up time of the package, the CLI and ``localize``, and the kernels' compile times."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from ._app import check_output, console, handle_errors
from .bench import bench_app


@bench_app.command("startup")
@handle_errors
def startup(
    runs: Annotated[int, typer.Option(min=1, help="Fresh processes timed per case (after one warm-up).")] = 7,
    cold_runs: Annotated[
        int, typer.Option(min=0, help="Runs of `localize` with an empty kernel cache (each compiles every kernel).")
    ] = 1,
    compile_table: Annotated[
        bool, typer.Option("--compile/--no-compile", help="Also time each kernel's compilation (the docs/speed.md table).")
    ] = False,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the results as JSON here.")] = None,
) -> None:
    """Start-up time: `import monovisual3d`, `--help`, `localize` on the paper scene (kernel cache warm and empty),
    the import time of each command's path; with --compile, each kernel's compile time."""
    from ..bench.startup import rows_to_dicts, run_compile_table, run_imports, run_localize, run_startup
    from ..bench.timing import machine_metadata

    check_output(output)
    rows = run_startup(runs)
    _print_rows(rows)
    with tempfile.TemporaryDirectory(prefix="mv3d-startup-") as folder:
        localize = run_localize(folder, runs, cold_runs)
        imports = run_imports(folder)
    _print_localize(localize)
    _print_imports(imports)
    kernels = run_compile_table() if compile_table else []
    if kernels:
        _print_compile(kernels)
    if output is not None:
        data: dict[str, Any] = {"machine": machine_metadata(), "rows": rows_to_dicts(rows), "localize": localize}
        data.update({"imports": imports, "compile": kernels})
        Path(output).write_text(json.dumps(data, indent=2) + "\n")


def _print_rows(rows: list[Any]) -> None:
    table = Table(title="Start-up (fresh process, wall seconds)")
    for col in ("case", "load", "runs", "median s", "min s", "max s", "target s", "met"):
        table.add_column(col, justify="right" if col not in ("case", "load") else "left")
    for r in rows:
        table.add_row(
            r.case,
            r.load,
            str(r.runs),
            f"{r.median_s:.3f}",
            f"{r.min_s:.3f}",
            f"{r.max_s:.3f}",
            f"{r.target_s:g}",
            "yes" if r.met else "NO",
        )
    console.print(table)


def _print_localize(localize: dict[str, Any]) -> None:
    table = Table(title="localize on the paper scene, whole process (seconds)")
    for col in ("kernel cache", "runs", "wall median", "wall min-max", "CPU median", "target", "met"):
        table.add_column(col, justify="left" if col == "kernel cache" else "right")
    for case, r in localize.items():
        w, c = r["wall_s"], r["cpu_s"]
        met = "yes" if r["met"] else "NO"
        table.add_row(
            case,
            str(r["runs"]),
            f"{w['median']:.2f}",
            f"{w['min']:.2f}-{w['max']:.2f}",
            f"{c['median']:.2f}",
            f"{r['target_s']:g}",
            met,
        )
    console.print(table)


def _print_imports(imports: dict[str, dict[str, float]]) -> None:
    table = Table(title="Imports of each command's path (python -X importtime, seconds)")
    for col in ("command", "median", "min-max"):
        table.add_column(col, justify="left" if col == "command" else "right")
    for name, s in imports.items():
        table.add_row(name, f"{s['median']:.3f}", f"{s['min']:.3f}-{s['max']:.3f}")
    console.print(table)


def _print_compile(kernels: list[dict[str, Any]]) -> None:
    table = Table(title="Kernel compile time, empty cache (seconds; a kernel includes its nested device functions)")
    for col in ("method", "kernel", "CPU s", "wall s"):
        table.add_column(col, justify="left" if col in ("method", "kernel") else "right")
    for k in kernels:
        name = ("  " if k["nested"] else "") + k["name"]
        table.add_row(k["method"], name, f"{k['cpu_s']:.2f}", f"{k['wall_s']:.2f}" if k["wall_s"] else "-")
    console.print(table)
