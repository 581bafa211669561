"""``view``: write the interactive 3D scene of a session (and its result, truth) as one offline HTML file."""

from __future__ import annotations

import webbrowser
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._app import app, check_output, command_budget, console, handle_errors, plain, print_warning
from .options import MaxMemory, TimeLimit


@app.command()
@handle_errors
def view(
    session: Annotated[Path, typer.Argument(help="Session file (JSON or YAML).")],
    result: Annotated[Path | None, typer.Option("--result", "-r", help="Result JSON written by `localize --output`.")] = None,
    truth: Annotated[
        Path | None, typer.Option("--truth", "-t", help='Truth JSON: {"objects": [{"position": [x, y, z], "radius": r}]}.')
    ] = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="HTML file to write.")] = Path("scene.html"),
    open_: Annotated[bool, typer.Option("--open", help="Open the file in the default web browser.")] = False,
    rrd: Annotated[
        Path | None, typer.Option("--rrd", help="Also write a rerun recording (.rrd) of the same scene (extra [rerun]).")
    ] = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Write an interactive 3D view (cameras, boxes, viewing cones, fruit, errors) as one self-contained HTML file.

    The file embeds plotly.js and works offline; open it in any web browser.
    """
    if output.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"--output: got {str(output)!r}, expected a file name ending in .html")
    if rrd is not None and rrd.suffix.lower() != ".rrd":
        raise InputError(f"--rrd: got {str(rrd)!r}, expected a file name ending in .rrd")
    check_output(output, session, result, truth)
    check_output(rrd, session, result, truth, flag="--rrd")
    from ..figures.html3d import write_scene_html

    with command_budget(time_limit, max_memory):  # a missing extra is said in one line (cli._app.handle_errors)
        path = write_scene_html(session, result, truth, path=output)
    console.print(f"wrote {plain(path)} ({path.stat().st_size / 1e6:.1f} MB, works offline)", highlight=False)
    if rrd is not None:
        from ..rerun_log import write_rrd

        with command_budget(time_limit, max_memory):
            written = write_rrd(session, result, truth, path=rrd)
        console.print(f"wrote {plain(written)} (open with `rerun {plain(written)}`)", highlight=False)
    if open_ and not webbrowser.open(path.resolve().as_uri()):  # False: no browser to run (a headless machine)
        print_warning(f"{path}: no web browser found to open it (--open); open the file in one by hand")
