"""``options``: the table of every option of a method (name, how to set it, default, who it is for, what it means)."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.table import Table
from rich.text import Text

from ..errors import InputError
from ..methods import METHODS
from ._app import app, console, handle_errors
from .options import GROUP_TITLES, MethodField, method_fields

#: What each audience means, printed under the tables (the decision itself: ``cli/options.py``, ``USER_OPTIONS``).
AUDIENCE_NOTE = (
    "for: user = a flag shown by `localize --help`; expert = a flag that --help hides and --help-all lists; "
    "developer = a developer knob (ablation switch, search effort): no flag, set it with --set NAME=VALUE. "
    "Every option is also a keyword of monovisual3d.localize(session, NAME=VALUE) and a `batch --option NAME=VALUE`."
)


@app.command("options")
@handle_errors
def options(
    method: Annotated[
        str | None, typer.Argument(metavar="METHOD", help=f"A method: {', '.join(METHODS)} (default: every method).")
    ] = None,
) -> None:
    """Every option of a method: how to set it, its default, who it is for and what it means.

    One table per section: the method's own options, then its option groups (bayes: the sensor model, and the
    developer knobs that only --set NAME=VALUE sets)."""
    if method is not None and method not in METHODS:
        raise InputError(f"METHOD: got {method!r}, expected one of {sorted(METHODS)}")
    for name in [method] if method is not None else list(METHODS):
        sections: dict[str, list[MethodField]] = {}
        for f in method_fields(METHODS[name]):
            sections.setdefault(f.group, []).append(f)
        for group, fields in sections.items():
            console.print(_table(_title(name, group, fields), fields))
    console.print(f"[dim]{AUDIENCE_NOTE}[/]", highlight=False)


def _title(method: str, group: str, fields: list[MethodField]) -> str:
    """``bayes method``, ``bayes sensor model (sensor)``, ``bayes developer knobs (tuning): --set NAME=VALUE``."""
    if not group:
        return f"{method} method"
    if all(f.audience == "developer" for f in fields):
        return f"{method} developer knobs ({group}): --set NAME=VALUE, no flags"
    return f"{method} {GROUP_TITLES.get(group, group)} ({group})"


def _table(title: str, fields: list[MethodField]) -> Table:
    """One section's options, a row each; every cell printed as typed (no markup)."""
    table = Table(title=title, title_justify="left")
    for col in ("option", "set with", "default", "for", "what it means"):
        table.add_column(col, overflow="fold")
    for f in fields:
        flag = "--" + f.name.replace("_", "-")
        if f.audience == "developer":
            how = f"--set {f.name}=" + ("true|false" if f.kind is bool else "VALUE")
        else:
            how = f"{flag}/--no-{flag[2:]}" if f.kind is bool else flag
        table.add_row(*(Text(cell) for cell in (f.name, how, f.default, f.audience, f.help)))
    return table
