"""``bench``: benchmarks (``bench speed``; other benchmarks register on :data:`bench_app`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from ._app import app, console, handle_errors, plain
from .options import LfdImageSize, ResultsOutput, SpreadScheduler, SpreadWorkers, spread_flags

bench_app = typer.Typer(
    help="Benchmarks: accuracy on simulated scenes, real data (LfD layout), dense rows (scale), integration mistakes (trust), "
    "speed, start-up, next-best-view and batch.",
    no_args_is_help=True,
    rich_markup_mode=None,
)
app.add_typer(bench_app, name="bench")


@bench_app.command("speed")
@handle_errors
def speed(
    quick: Annotated[bool, typer.Option("--quick", help="Small grids, two repetitions: a few seconds.")] = False,
    output: ResultsOutput = None,
    edges: Annotated[
        str | None, typer.Option(help="Cells per grid axis, comma separated (default 63,126,252: 0.25/2/16 M cells).")
    ] = None,
    kernel: Annotated[str, typer.Option(help="Kernels, comma separated: square, gaussian.")] = "square,gaussian",
    repeats: Annotated[
        int | None, typer.Option(min=1, help="Timed repetitions after one warm-up (default 5; 2 with --quick).")
    ] = None,
    device: Annotated[
        str | None, typer.Option(help="Torch device for the torch backend (cpu, cuda; default: cuda if available).")
    ] = None,
    refine_to: Annotated[float, typer.Option(help="Effective resolution (metres) of the sparse coarse-to-fine run.")] = 0.001,
    no_scaling: Annotated[bool, typer.Option("--no-scaling", help="Skip the scaling with views and boxes.")] = False,
    threads: Annotated[int | None, typer.Option(min=1, help="numba threads (default: one per core).")] = None,
    methods: Annotated[
        str, typer.Option(help="Methods, comma separated: naive-python, numpy, numba, numba-filter, sparse, torch.")
    ] = "naive-python,numpy,numba,numba-filter,sparse,torch",
) -> None:
    """Time the per-view update: naive Python loop, numpy, fused numba, sparse, torch."""
    from ..bench.speed import format_table, run_speed
    from ..bench.timing import write_json

    edge_t, chosen, kernels = _speed_choices(edges, methods, kernel)
    result = run_speed(
        quick=quick,
        edges=edge_t,
        kernels=kernels,
        repeats=repeats,
        torch_device=device,
        sparse_refine_to=refine_to,
        scaling=not no_scaling,
        threads=threads,
        methods=chosen,
        progress=lambda msg: console.print(f"[dim]running {plain(msg)}[/]", highlight=False),
    )
    meta = result["meta"]
    table = Table(
        title="Per-view update, mean of the paper's 3 views, paper scene "
        f"({plain(meta['cpu'])}, {meta['cores']} cores, numba {meta.get('numba')}, load {meta.get('load_average_1m', float('nan')):.1f})"
    )
    for col in ("method", "kernel", "cells", "ms/view median [min-max]", "CPU ms", "cells/s", "vs naive", "B/cell", "notes"):
        table.add_column(col, justify="left" if col in ("method", "kernel", "notes") else "right", no_wrap=col != "notes")
    for row in format_table(result):
        table.add_row(*row)
    console.print(table)
    _print_speed_lines(result)
    if output is not None:
        write_json(result, str(output))
        console.print(f"wrote {plain(output)}", highlight=False)


def _speed_choices(
    edges: str | None, methods: str, kernel: str
) -> tuple[tuple[int, ...] | None, tuple[str, ...], tuple[str, ...]]:
    """Parse and check the comma-separated ``--edges``, ``--methods`` and ``--kernel`` of ``bench speed``."""
    from ..errors import InputError

    try:
        edge_t = tuple(int(e) for e in edges.split(",")) if edges else None
    except ValueError:
        raise InputError(f"--edges: got {edges!r}, expected integers separated by commas") from None
    from ..bench.speed import METHODS

    chosen = tuple(m.strip() for m in methods.split(","))
    for m in chosen:
        if m not in METHODS:
            raise InputError(f"--methods: got {m!r}, expected some of {', '.join(METHODS)}")
    kernels = tuple(k.strip() for k in kernel.split(","))
    for k in kernels:
        if k not in ("square", "gaussian"):
            raise InputError(f"--kernel: got {k!r}, expected square and/or gaussian")
    return edge_t, chosen, kernels


def _print_speed_lines(result: dict[str, Any]) -> None:
    """Print the lines of ``bench speed`` below its table: skipped methods, sparse, scaling, end to end."""
    meta = result["meta"]
    for note in meta.get("skipped", []):
        console.print(f"[yellow]skipped:[/] {plain(note)}", highlight=False)
    for r in result["sparse_fine"]:
        console.print(
            f"sparse {r['kernel']}: {r['refine_to_mm']:g} mm over {r['virtual_cells'] / 1e9:.2f} G virtual cells, "
            f"{r['per_view_ms']['median']:.1f} ms/view, {r['active_cells']:,} active cells, "
            f"{r['peak_bytes'] / 2**20:.0f} MiB peak, reached {1e3 * r['final_resolution_m']:g} mm"
            + ("" if r["complete"] else " (stopped by max_cells)"),
            highlight=False,
        )
    sc = result.get("scaling") or {}
    for r in sc.get("views", []):
        console.print(
            f"views {r['views']}: sequential {r['sequential_ms']['median']:.1f} ms, one pass {r['one_pass_ms']['median']:.1f} ms "
            f"({r['cells'] / 1e6:.2f} M cells, gaussian)",
            highlight=False,
        )
    for r in sc.get("boxes", []):
        console.print(
            f"boxes {r['boxes']}: {r['per_view_ms']['median']:.2f} ms/view ({r['cells'] / 1e6:.2f} M cells, gaussian)",
            highlight=False,
        )
    for r in result.get("end_to_end", []):
        sec = r["seconds"]
        console.print(
            f"end-to-end localize, paper scene (6 fruit, 3 views), {r['config']}, {r.get('load', 'idle')}: "
            f"{1e3 * sec['median']:.0f} ms [{1e3 * sec['min']:.0f}-{1e3 * sec['max']:.0f}]",
            highlight=False,
        )
    paper = result.get("paper_default_vs_numpy")
    if paper:
        console.print(
            f"{paper['config']}: {1e3 * paper['default_s']['median']:.0f} ms vs {1e3 * paper['numpy_s']['median']:.0f} ms, "
            f"{paper['speedup']:.1f}x",
            highlight=False,
        )


@bench_app.command("real")
@handle_errors
def real(
    folder: Annotated[
        Path | None, typer.Argument(help="Folder of LfD arrays (default: the shared Aldoma set, ../shared/data/aldoma).")
    ] = None,
    methods: Annotated[
        str, typer.Option(help="Runs, comma separated: bayes, paper, quadric (tracks), quadric (bayes).")
    ] = "bayes,paper,quadric (tracks),quadric (bayes)",
    reach: Annotated[float, typer.Option(min=0.01, help="Search reach of every method, metres.")] = 1.0,
    subset_size: Annotated[int, typer.Option("--subset-size", min=1, help="Views per subset.")] = 3,
    image_size: LfdImageSize = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results (with machine metadata) as JSON.")] = False,
    output: ResultsOutput = None,
    workers: SpreadWorkers = None,
    scheduler: SpreadScheduler = None,
) -> None:
    """Real multi-view scene (LfD layout): centre error per method on all views and on every 3-view subset."""
    from rich.progress import Progress

    from ..bench.real import format_markdown, run_real, to_json
    from ..io.image_size import parse_image_size
    from ._app import check_output, write_output

    check_output(output, folder)
    with spread_flags(workers, scheduler), Progress(console=console.rich, transient=True) as bar:
        task = bar.add_task("real-data benchmark", total=None)
        results = run_real(
            folder,
            methods=tuple(m.strip() for m in methods.split(",")),
            subset_size=subset_size,
            reach=reach,
            image_size=None if image_size is None else parse_image_size(image_size),
            workers=workers,
            scheduler=scheduler,
            progress=lambda msg: bar.update(task, description=msg),
        )
    text = to_json(results)
    print(text if as_json else format_markdown(results))  # plain Markdown, so the table can be pasted as it is
    if output is not None:
        write_output(output, text + "\n")
        console.print(f"wrote {plain(str(output))}", highlight=False)


@bench_app.command("scale")
@handle_errors
def scale(
    fruit: Annotated[str, typer.Option(help="Fruit counts of the fruit sweep (5 views), comma separated.")] = "12,24,48,96,192",
    views: Annotated[str, typer.Option(help="View counts of the view sweep (48 fruit), comma separated.")] = "3,5,8",
    seeds: Annotated[str, typer.Option(help="Scene seeds, comma separated (the time is the median over them).")] = "0,1,2",
    repeats: Annotated[
        int, typer.Option(min=1, help="Timed calls per scene (their median is its time), made in rounds over all cases.")
    ] = 1,
    busy: Annotated[bool, typer.Option("--busy/--idle-only", help="Also run with a busy-loop process on one core.")] = True,
    output: ResultsOutput = None,
    figure: Annotated[Path | None, typer.Option(help="Write a log-log figure of time against boxes here (PNG).")] = None,
) -> None:
    """The default method on plant rows of 12-192 fruit and 3-8 views: time, error, recall, growth factor."""
    from ..bench.scale import TARGET_GROWTH, format_table, run_scale, write_figure, write_json

    result = run_scale(
        _ints(fruit, "--fruit"),
        _ints(views, "--views"),
        _ints(seeds, "--seeds"),
        repeats,
        busy,
        progress=lambda msg: console.print(f"[dim]running {msg}[/]", highlight=False),
    )
    meta = result["meta"]
    table = Table(
        title=f"bayes on a plant row, 1280x720, 3 % box noise, median over seeds {meta['seeds']} "
        f"({meta['cpu']}, {meta['cores']} cores, load {meta.get('load_average_1m', float('nan')):.1f})"
    )
    for col in ("load", "fruit", "views", "boxes/view", "time s", "CPU s", "mean mm", "recall", "precision"):
        table.add_column(col, justify="left" if col == "load" else "right")
    for row in format_table(result):
        table.add_row(*row)
    console.print(table)
    for load, g in result["growth"].items():
        console.print(
            f"growth {load}: time({g['to']} fruit) / time({g['from']} fruit) = {g['ratio']:.1f} "
            f"(target <= {TARGET_GROWTH:g} for 12 -> 96)",
            highlight=False,
        )
    if output is not None:
        write_json(result, str(output))
        console.print(f"wrote {plain(str(output))}", highlight=False)
    if figure is not None:
        write_figure(result, str(figure))
        console.print(f"wrote {plain(str(figure))}", highlight=False)


def _ints(text: str, flag: str) -> list[int]:
    """Comma-separated integers of a flag."""
    from ..errors import InputError

    try:
        return [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise InputError(f"{flag}: got {text!r}, expected integers separated by commas") from None


ab_app = typer.Typer(
    help="A/B of localize options: the default against KEY=VALUE changes, runtime or accuracy, side by side.",
    no_args_is_help=True,
    rich_markup_mode=None,
)
bench_app.add_typer(ab_app, name="ab")
ABOptions = Annotated[
    list[str] | None,
    typer.Argument(
        help="localize options to compare with the default, KEY=VALUE (values read as JSON where they parse: "
        "radius_max=0.08, size_range=[0.01,0.15], regroup=false); none: the default alone.",
        show_default=False,
    ),
]


@ab_app.command("time")
@handle_errors
def ab_time(
    options: ABOptions = None,
    rounds: Annotated[int, typer.Option(min=1, help="Timed rounds after one warm-up of each variant.")] = 5,
) -> None:
    """Median localize time (ms) of the default and of the changed options, alternated in one process.

    On the paper scene (6 fruit, 3 views, the paper's box noise, one fixed draw) and on six fruit of mixed shapes (five draws).
    """
    from ..bench.option_ab import format_time, time_options, variants

    chosen = variants(options or [])
    result = time_options(chosen, rounds, progress=lambda msg: console.print(f"[dim]{msg}[/]", highlight=False))
    for line in format_time(result):
        print(line)


@ab_app.command("accuracy")
@handle_errors
def ab_accuracy(
    condition: Annotated[str, typer.Argument(help="A condition of bench accuracy, e.g. greenhouse-noise.")],
    first: Annotated[int, typer.Argument(min=0, help="First seed.")],
    last: Annotated[int, typer.Argument(min=1, help="Last seed, excluded.")],
    options: ABOptions = None,
) -> None:
    """Centre error, recall and precision of the default and of the changed options on seeds FIRST..LAST-1."""
    from ..bench.option_ab import accuracy_options, format_accuracy, variants
    from ..errors import InputError

    if last <= first:
        raise InputError(f"LAST: got {last}, expected more than FIRST ({first})")
    chosen = variants(options or [])
    seeds = range(first, last)
    for line in format_accuracy(condition, seeds, accuracy_options(condition, seeds, chosen)):
        print(line)


@bench_app.command("trust")
@handle_errors
def trust(
    quick: Annotated[bool, typer.Option("--quick", help="One seed, the paper and arc families, 5 % box noise.")] = False,
    seeds: Annotated[str | None, typer.Option(help="Seeds, comma separated (default 0,1; fresh ones: any others).")] = None,
    families: Annotated[
        str | None, typer.Option(help="Scene families, comma separated: paper, greenhouse, arc, row (default all).")
    ] = None,
    mistakes: Annotated[
        str | None, typer.Option(help="Mistake classes, comma separated (default all; see docs/trust.md).")
    ] = None,
    run_limit: Annotated[
        float, typer.Option(min=0.1, help="CPU seconds one session may use; a run past it counts as not caught.")
    ] = 10.0,
    output: ResultsOutput = None,
    workers: SpreadWorkers = None,
    scheduler: SpreadScheduler = None,
) -> None:
    """Integration mistakes on simulated sessions: share caught and named, false alarms, NEES of the covariance."""
    from rich.progress import Progress

    from ..bench.trust import format_markdown, run_trust, save
    from ._app import check_output

    check_output(output)
    with spread_flags(workers, scheduler), Progress(console=console.rich, transient=True) as bar:
        task = bar.add_task("trust benchmark", total=None)
        results = run_trust(
            seeds=tuple(_ints(seeds, "--seeds")) if seeds else None,
            families=_names(families),
            mistakes=_names(mistakes),
            quick=quick,
            run_limit_s=run_limit,
            progress=lambda msg: bar.update(task, description=plain(msg)),
            workers=workers,
            scheduler=scheduler,
        )
    print(format_markdown(results))  # plain Markdown, so the table can be pasted as it is
    if output is not None:
        save(results, str(output))
        console.print(f"wrote {plain(str(output))}", highlight=False)


def _names(text: str | None) -> tuple[str, ...] | None:
    """Comma-separated names of a flag (None when not given)."""
    return tuple(t.strip() for t in text.split(",") if t.strip()) if text else None
