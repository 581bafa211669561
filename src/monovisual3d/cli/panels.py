"""The help panels of the commands with method options (``localize``): their names, the command class that prints
them, and ``--help-all``, which shows the hidden flags too.

The app's other commands keep click's plain help, which loads faster (``monovisual3d --help`` loads no rich help
renderer); a :class:`PanelCommand` loads typer's rich renderer only when its own help is asked for.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Annotated, Any

import typer
import typer.core

#: ``localize --help``'s panels, in the order they print (typer's default panel, "Options", is not used: it would
#: print first).
PANEL_FIND = "What to find"
PANEL_SCENE = "Scene and poses"
PANEL_OUTPUT = "Output"
PANEL_LIMITS = "Limits"
PANEL_MORE = "More options"
#: The order the panels print in; others (the experts' panels of ``--help-all``) come before :data:`PANEL_MORE`.
PANELS = (PANEL_FIND, PANEL_SCENE, PANEL_OUTPUT, PANEL_LIMITS)
#: The panel of the expert options several methods share (``--backend``, ``--resolution``, ``--min-views``).
PANEL_SHARED = "Expert: several methods"


class PanelCommand(typer.core.TyperCommand):
    """A command whose ``--help`` shows its options in rich panels (their ``rich_help_panel``, in :data:`PANELS`
    order, :data:`PANEL_MORE` last, with ``--help`` itself), help texts as plain text (as everywhere in this CLI:
    ``[default: 2]`` prints as typed, it is not markup)."""

    def get_help_option(self, ctx: Any) -> Any:
        option = super().get_help_option(ctx)
        if option is not None:
            option.rich_help_panel = PANEL_MORE
        return option

    def format_help(self, ctx: Any, formatter: Any) -> None:
        from rich.markup import escape
        from typer import rich_utils

        texts = [(p, p.help) for p in [*self.params, self] if getattr(p, "help", None)]
        params = self.params
        try:
            for p, text in texts:
                p.help = escape(text)
            self.params = sorted(params, key=_panel_rank)  # typer prints the panels in the order the params come
            rich_utils.rich_format_help(obj=self, ctx=ctx, markup_mode="rich")
        finally:
            self.params = params
            for p, text in texts:
                p.help = text


def _panel_rank(param: Any) -> int:
    panel = getattr(param, "rich_help_panel", None)
    return PANELS.index(panel) if panel in PANELS else len(PANELS) + (panel == PANEL_MORE)


def help_all_parameter(after: Callable[[], None]) -> inspect.Parameter:
    """The ``--help-all`` flag as a keyword parameter of a command: the help with the hidden flags shown too (in
    their panels), then ``after()`` (what no flag reaches), then exit."""

    def show(ctx: typer.Context, param: typer.CallbackParam, value: bool) -> None:
        if not value or ctx.resilient_parsing:
            return
        hidden = [p for p in ctx.command.params if getattr(p, "hidden", False)]
        try:
            for p in hidden:
                p.hidden = False  # type: ignore[attr-defined]
            text = ctx.get_help()  # a PanelCommand prints its panels itself and returns ""
            if text:
                typer.echo(text)
        finally:
            for p in hidden:
                p.hidden = True  # type: ignore[attr-defined]
        after()
        ctx.exit()

    option = typer.Option(
        "--help-all",
        help="Show every option (the experts' in their methods' panels) and the developer knobs of --set; then exit.",
        is_eager=True,
        expose_value=False,
        callback=show,
        rich_help_panel=PANEL_MORE,
    )
    return inspect.Parameter("help_all", inspect.Parameter.KEYWORD_ONLY, default=False, annotation=Annotated[bool, option])


def print_table_panels(panels: dict[str, list[tuple[str, str, str]]]) -> None:
    """Panels of rows (flag, type, help), as typer prints its own, under the same console settings; text printed
    as typed (not markup)."""
    from rich.console import Console
    from rich.panel import Panel
    from rich.table import Table
    from rich.text import Text

    console = Console()
    for title, rows in panels.items():
        table = Table(show_header=False, box=None, expand=True, pad_edge=False, padding=(0, 1))
        for flag, kind, text in rows:
            table.add_row(Text(flag, style="bold cyan"), Text(kind, style="bold yellow"), Text(text))
        console.print(Panel(table, title=title, title_align="left", border_style="dim"))
