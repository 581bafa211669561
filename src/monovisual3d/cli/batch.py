"""``batch``: localise many sessions on a Dask cluster into two tables; ``bench batch``: its throughput."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ..limits import MAX_LOCAL_WORKERS
from ._app import app, check_output, command_budget, console, handle_errors, plain, print_warning
from .bench import bench_app
from .options import BatchTimeLimit, parse_options, spread_flags

#: ``--max-worker-deaths``: how often a task may kill its worker before its sessions are retried one by one.
MaxWorkerDeaths = Annotated[
    int,
    typer.Option(
        min=1,
        help="Worker deaths a task (a chunk of sessions) may cause before it fails; its sessions are then retried one by one with the same allowance (local cluster).",
    ),
]
#: ``--chunk-size``: sessions per Dask task.
ChunkSize = Annotated[
    int | None,
    typer.Option(
        min=1, help="Sessions per Dask task (default: up to 16, at least 4 tasks per worker; not used with --workers 0)."
    ),
]


@app.command()
@handle_errors
def batch(
    inputs: Annotated[list[str], typer.Argument(help="Session files, folders (searched for session.json/.yaml) or globs.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Folder for fruit/sessions .parquet and .csv, summary.json.")],
    workers: Annotated[
        int | None,
        typer.Option(
            min=0,
            help="Local worker processes (default: one per core; 0: in this process, without a Dask cluster; either way the "
            "dask extra, whose pandas and pyarrow write the tables).",
        ),
    ] = None,
    scheduler: Annotated[str | None, typer.Option(help="Address of a running Dask scheduler, e.g. tcp://host:8786.")] = None,
    method: Annotated[str | None, typer.Option(help="Localisation method (default: localize's default).")] = None,
    option: Annotated[
        list[str] | None,
        typer.Option("--option", help="Method option KEY=VALUE (VALUE read as JSON when it parses); repeatable."),
    ] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Skip sessions already in --output (same id, content and options).")
    ] = False,
    part_size: Annotated[int, typer.Option(min=1, help="Sessions per written part file.")] = 100,
    max_worker_deaths: MaxWorkerDeaths = 3,
    chunk_size: ChunkSize = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    strict: Annotated[
        bool,
        typer.Option(
            "--strict",
            help="Exit 1 also when a session's verdict is not ok or its result is incomplete: empty although two or more "
            "views have boxes, or boxes no object holds (as localize --strict; sessions.csv, columns verdict, warnings).",
        ),
    ] = False,
    time_limit: BatchTimeLimit = None,
    max_memory: Annotated[
        str | None, typer.Option("--max-memory", help="Memory budget of each session's method, e.g. 2GiB (--option max_memory).")
    ] = None,
) -> None:
    """Localise many sessions in parallel; write one table of fruit and one of sessions.

    Bad sessions are recorded with their error and the batch goes on; the exit
    code is 1 when any session failed (with --strict, also when any result is
    incomplete), 2 on a usage error.
    """
    from ..batch import run

    if workers is not None and scheduler is not None:
        raise InputError("--workers, --scheduler: give one of them (--scheduler uses the cluster's workers)")
    options = _method_options(option, max_memory)
    kwargs = dict(
        method=method,
        workers=workers,
        scheduler=scheduler,
        resume=resume,
        part_size=part_size,
        max_worker_deaths=max_worker_deaths,
        chunk_size=chunk_size,
    )
    with spread_flags(workers, scheduler), _option_flags(options), command_budget(time_limit):
        tables = run(inputs, output, **kwargs, **options) if quiet else _run_with_bar(inputs, output, kwargs, options)
    _report(tables, output, strict)


def _method_options(option: list[str] | None, max_memory: str | None) -> dict[str, Any]:
    """The method options of ``--option NAME=VALUE`` and ``--max-memory`` (one of the two for the memory budget)."""
    options = parse_options(option)
    if max_memory is not None:
        if "max_memory" in options:
            raise InputError("--max-memory, --option max_memory: give one of them")
        options["max_memory"] = max_memory
    return options


@contextlib.contextmanager
def _option_flags(options: dict[str, Any]) -> Iterator[None]:
    """Name a method option as typed (``--option resolution: ...``) in the errors raised about it."""
    try:
        yield
    except InputError as exc:
        key = str(exc).partition(":")[0]
        if key in options:
            raise InputError(f"--option {exc}") from None
        raise


def _run_with_bar(inputs: list[str], output: Path, kwargs: dict[str, Any], options: dict[str, Any]) -> Any:
    """:func:`monovisual3d.batch.run` with a rich progress bar, after a line saying where the sessions run.

    The bar starts at the first progress report, which comes after the inputs were checked and found:
    a bad input (an empty folder) prints its error alone, with no ``0/?`` bar before it.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from ..batch import BatchProgress, run

    announce = _announcer(kwargs.get("scheduler"))
    columns = (
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]:.2f} sessions/s"),
        TextColumn("[red]{task.fields[failed]} failed"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
    )
    bar = Progress(*columns, console=console.rich, transient=False)
    task = bar.add_task("batch", total=None, rate=0.0, failed=0)

    def progress(p: BatchProgress) -> None:
        announce(p)
        if not bar.live.is_started:
            bar.start()
        rate = p.done / p.elapsed_s if p.elapsed_s > 0 else 0.0
        bar.update(task, completed=p.done, total=p.total, rate=rate, failed=p.failed)

    try:
        return run(inputs, output, **kwargs, progress=progress, **options)
    finally:
        if bar.live.is_started:
            bar.stop()


def _announcer(scheduler: str | None) -> Callable[[Any], None]:
    """A progress callback that prints, once, how many sessions run where and the Dask dashboard's address."""
    shown: dict[str, bool] = {"dashboard": False}

    def announce(p: Any) -> None:
        if not shown["dashboard"]:
            shown["dashboard"] = True
            if p.workers == 0:
                where = "in this process"
            elif scheduler is None:
                where = f"on {p.workers} worker process(es)"
            else:  # a running cluster's workers may have several threads each: count what runs at once
                where = f"on the Dask cluster at {plain(scheduler)} ({p.workers} worker threads)"
            console.print(f"running {p.total} session(s) {where}" + (f"; {p.skipped} already done" if p.skipped else ""))
            if p.dashboard:
                console.print(f"Dask dashboard: {plain(p.dashboard)}", highlight=False)

    return announce


def _report(tables: Any, output: Path, strict: bool = False) -> None:
    """Print the batch summary, the evaluation against truth and the first failures; exit 1 when any session failed."""
    s = tables.summary
    line = f"{s['n_ok']} ok, {s['n_error']} failed, {s['n_fruit']} fruit; wrote {plain(output)}/fruit.parquet, sessions.parquet (+ .csv), summary.json"
    console.print(line, highlight=False)
    if "evaluation" in s:
        e = s["evaluation"]
        console.print(
            f"against truth.json ({e['n_sessions']} sessions): recall {e['recall']:.3f}, precision {e['precision']:.3f}, "
            f"mean error {1000 * e['error_mean_m']:.1f} mm",
            highlight=False,
        )
    if s["n_error"]:
        failed = tables.sessions[tables.sessions["status"] != "ok"]
        for _, row in failed.head(5).iterrows():
            console.print(f"[red]failed:[/] {plain(row['session_id'])}: {plain(row['error'])}", highlight=False)
        if len(failed) > 5:
            console.print(f"... and {len(failed) - 5} more (sessions.csv, column error)")
    incomplete = _incomplete(tables.sessions)
    if incomplete:
        session_id, reason = incomplete[0]
        print_warning(
            f"{len(incomplete)} session(s) with an incomplete result (sessions.csv, column warnings), "
            f"the first: {session_id}: {reason}"
        )
    flagged = _flagged(tables.sessions)
    if flagged:
        session_id, verdict, causes = flagged[0]
        print_warning(
            f"{len(flagged)} session(s) with a verdict that is not ok (sessions.csv, columns verdict, causes, warnings), "
            f"the first: {session_id}: {verdict} ({causes})"
        )
    if s["n_error"] or (strict and (incomplete or flagged)):
        raise typer.Exit(1)


def _flagged(sessions: Any) -> list[tuple[str, str, str]]:
    """(session id, verdict, causes) of each ok session whose quality verdict is not ``ok`` (:mod:`monovisual3d.verdict`)."""
    out = []
    for _, row in sessions[sessions["status"] == "ok"].iterrows():
        verdict = row["verdict"]
        if isinstance(verdict, str) and verdict != "ok":
            out.append((str(row["session_id"]), verdict, str(row["causes"])))
    return out


def _incomplete(sessions: Any) -> list[tuple[str, str]]:
    """(session id, first reason) of each ok session whose result is incomplete (:mod:`monovisual3d.completeness`)."""
    from ..completeness import is_incomplete_reason

    out = []
    for _, row in sessions[sessions["status"] == "ok"].iterrows():
        warnings = json.loads(row["warnings"]) if isinstance(row["warnings"], str) and row["warnings"] else []
        reasons = [w for w in warnings if is_incomplete_reason(w)]
        if reasons:
            out.append((str(row["session_id"]), reasons[0]))
    return out


@bench_app.command("batch")
@handle_errors
def bench_batch(
    sessions: Annotated[int, typer.Option("--sessions", "-n", min=1, help="Simulated paper-scene sessions.")] = 1000,
    workers: Annotated[str, typer.Option(help="Worker counts to time, comma separated.")] = "1,2",
    method: Annotated[str, typer.Option(help="Localisation method.")] = "paper",
    option: Annotated[
        list[str] | None, typer.Option("--option", help="Method option KEY=VALUE (default for paper: backend=numba).")
    ] = None,
    data: Annotated[
        Path | None, typer.Option(help="Folder for the simulated sessions (kept and reused; default a temporary folder).")
    ] = None,
    repeats: Annotated[int, typer.Option(min=1, help="Timed runs of each configuration (the median is reported).")] = 1,
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Write the results with machine metadata as JSON.")
    ] = None,
) -> None:
    """Sessions per second of 'batch' with 1 and 2 workers, and its overhead over 'localize' in a loop."""
    from ..bench.batch import format_rows, run_bench_batch

    check_output(output)

    try:
        counts = tuple(int(w) for w in workers.split(","))
    except ValueError:
        raise InputError(f"--workers: got {workers!r}, expected integers separated by commas") from None
    if any(c < 1 for c in counts):
        raise InputError(f"--workers: got {workers!r}, expected positive worker counts")
    if any(c > MAX_LOCAL_WORKERS for c in counts):
        raise InputError(f"--workers: got {workers!r}, more than the {MAX_LOCAL_WORKERS} local processes accepted")
    options = parse_options(option) if option else ({"backend": "numba"} if method == "paper" else {})
    result = run_bench_batch(
        n_sessions=sessions,
        worker_counts=counts,
        method=method,
        options=options,
        data=data,
        repeats=repeats,
        progress=lambda msg: console.print(f"[dim]{plain(msg)}[/]", highlight=False),
    )
    for line in format_rows(result):
        console.print(line, highlight=False)
    if output is not None:
        output.write_text(json.dumps(result, indent=2) + "\n")
        console.print(f"wrote {plain(output)}", highlight=False)
