"""``warmup``: compile every kernel ahead of time."""

from __future__ import annotations

from typing import Annotated

import typer

from ._app import app, console, handle_errors


@app.command()
@handle_errors
def warmup(
    methods: Annotated[
        str, typer.Option(help="Methods whose kernels to compile, comma separated (default: every compiled one).")
    ] = "",
) -> None:
    """Compile the kernels now (cached on disk), so that the first `localize` does not wait: for a robot before its
    first view, or a Docker image build."""
    from ..api import warmup as warm

    names = [m.strip() for m in methods.split(",") if m.strip()] or None
    for method, seconds in warm(names).items():
        console.print(f"{method}: kernels ready in {seconds:.1f} s", highlight=False)
