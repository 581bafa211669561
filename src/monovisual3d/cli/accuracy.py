"""``bench accuracy``: the accuracy benchmark of the localisation methods."""

from __future__ import annotations

from typing import Annotated

import typer

from ._app import check_output, console, handle_errors, plain
from .bench import bench_app
from .options import ResultsOutput, SpreadScheduler, SpreadWorkers, spread_flags


@bench_app.command("accuracy")
@handle_errors
def accuracy(
    quick: Annotated[bool, typer.Option("--quick", help="Fewer seeds and fruit counts (about 20 s).")] = False,
    methods: Annotated[
        str, typer.Option(help="Methods, comma separated: bayes, bayes+masks, bayes-2cm, bayes-strict, bayes-unstated, paper.")
    ] = "bayes,bayes+masks,paper",
    only: Annotated[
        str | None, typer.Option(help="Only these conditions, comma separated (e.g. paper-clean,greenhouse).")
    ] = None,
    output: ResultsOutput = None,
    workers: SpreadWorkers = None,
    scheduler: SpreadScheduler = None,
) -> None:
    """Fixed-seed simulated scenes: error, recall, precision, radius error and runtime per method."""
    from rich.progress import Progress

    from ..bench.accuracy import format_markdown, run_accuracy, save

    check_output(output)
    with spread_flags(workers, scheduler), Progress(console=console.rich, transient=True) as bar:
        task = bar.add_task("accuracy benchmark", total=None)
        results = run_accuracy(
            quick=quick,
            methods=tuple(m.strip() for m in methods.split(",")),
            only=tuple(c.strip() for c in only.split(",")) if only else None,
            progress=lambda msg: bar.update(task, description=plain(msg)),
            workers=workers,
            scheduler=scheduler,
        )
    # plain Markdown, so the table can be pasted as it is (the README's table comes from here)
    print(format_markdown(results))
    if output is not None:
        save(results, str(output))
        console.print(f"wrote {plain(output)}", highlight=False)
