"""Command-line interface: ``monovisual3d`` (alias ``mv3d``).

The CLI only parses arguments and calls the library. User errors end with
exit code 2 and a one-line message; warnings are printed as one line each.

Each command lives in one module of this package, which registers it on the application when imported.
:func:`main` imports only the module of the command its command line names, with what that module imports itself
(the others' imports are 0.04 s of every command's start, issue 56); ``app`` (``from monovisual3d.cli import app``)
is the application with every command registered.
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import typer

#: Every module that registers commands, in the order they are imported for the whole application.
MODULES = (
    "accuracy",
    "active",
    "batch",
    "bench",
    "core",
    "experiments",
    "io",
    "reference",
    "ros2",
    "sim",
    "startup",
    "view",
    "warmup",
)
#: The module that registers each top-level command or group. A command line that names one of these imports that
#: module (and what it imports); any other (``--help``, the ``bench`` group, whose commands several modules register,
#: a plug-in's command) imports every module.
COMMAND_MODULES = {
    "demo": "experiments",
    "reproduce": "experiments",
    "localize": "core",
    "evaluate": "core",
    "view": "view",
    "import": "io",
    "import-bag": "io",
    "import-lfd": "io",
    "options": "reference",
    "simulate": "sim",
    "next-view": "active",
    "batch": "batch",
    "warmup": "warmup",
    "ros2": "ros2",
}

__all__ = ["COMMAND_MODULES", "MODULES", "app", "load_commands", "main"]


def load_commands(modules: tuple[str, ...] = MODULES) -> None:
    """Import the command ``modules`` of this package (their commands register themselves on the application)."""
    for name in modules:
        importlib.import_module(f"{__name__}.{name}")


def __getattr__(name: str) -> Any:
    if name == "app":  # the whole application: every command registered
        load_commands()
        from ._app import app

        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def main() -> None:
    """Console-script entry point: the command the command line names, its module alone imported where it has one."""
    from ._app import main as run

    module = COMMAND_MODULES.get(sys.argv[1]) if len(sys.argv) > 1 else None
    load_commands((module,) if module else MODULES)
    run()


if TYPE_CHECKING:
    app: typer.Typer
