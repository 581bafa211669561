"""``bench startup``: start-up time of the package and the CLI."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from ._app import check_output, console, handle_errors
from .bench import bench_app


@bench_app.command("startup")
@handle_errors
def startup(
    runs: Annotated[int, typer.Option(min=1, help="Fresh processes timed per case (after one warm-up).")] = 7,
    output: Annotated[Path | None, typer.Option("--output", "-o", help="Write the rows as JSON here.")] = None,
) -> None:
    """Start-up time: `import monovisual3d` and `monovisual3d --help`, idle and with a busy core."""
    from ..bench.startup import rows_to_dicts, run_startup
    from ..bench.timing import machine_metadata

    check_output(output)
    rows = run_startup(runs)
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
    if output is not None:
        Path(output).write_text(json.dumps({"machine": machine_metadata(), "rows": rows_to_dicts(rows)}, indent=2) + "\n")
