"""The Typer application and the shared error handling of all commands."""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import sys
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import typer
import typer.core

from ..budget import TimeLimitExceeded, memory_limit, time_limit
from ..errors import InputError, MissingExtra, one_line

if TYPE_CHECKING:
    from rich.console import Console

#: The order ``monovisual3d --help`` lists the commands in: a newcomer's path first (try it, run it on a session,
#: check and see the result, bring one's own data), then the rest; commands not named here follow in their order.
COMMAND_ORDER = (
    "demo",
    "localize",
    "evaluate",
    "view",
    "import",
    "import-lfd",
    "import-bag",
    "options",
    "simulate",
    "next-view",
    "ros2",
    "batch",
    "reproduce",
    "warmup",
    "bench",
)


class _Commands(typer.core.TyperGroup):
    """The top-level group, its commands listed in :data:`COMMAND_ORDER` (registration follows module imports)."""

    def list_commands(self, ctx: Any) -> list[str]:
        names = super().list_commands(ctx)
        return sorted(names, key=lambda n: COMMAND_ORDER.index(n) if n in COMMAND_ORDER else len(COMMAND_ORDER))


app = typer.Typer(
    cls=_Commands,
    name="monovisual3d",
    help="Localise fruit in 3D from 2D detections of a monocular camera at known poses.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    # plain help (click's formatter): rich's help renderer takes ~0.12 s to load, a third of --help
    rich_markup_mode=None,
)


def _version(value: bool) -> None:
    if value:
        from .. import __version__

        print(f"monovisual3d {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print the version and exit.", callback=_version, is_eager=True),
) -> None:
    """Localise fruit in 3D from 2D detections of a monocular camera at known poses."""


#: Width given to tables when the output is not a terminal (a file or a pipe): wide enough that no cell wraps.
PIPE_WIDTH = 400


class LazyConsole:
    """A rich ``Console`` made on first use: importing rich is 0.02-0.03 s of a command's start (issue 56), and a
    ``localize -q`` that succeeds prints nothing. Attributes are the console's; :attr:`rich` is the console itself,
    for what takes one (``Progress(console=console.rich)``).

    soft_wrap: a line is never cut by rich, so piped output keeps "5.5 mm" whole (see :func:`_fit_consoles` for
    tables).
    """

    def __init__(self, stderr: bool = False) -> None:
        self._stderr = stderr
        self._console: Console | None = None

    @property
    def rich(self) -> Console:
        """The console (made and fitted to its output on first use)."""
        if self._console is None:
            from rich.console import Console

            self._console = Console(stderr=self._stderr, soft_wrap=True)
            _fit(self._console)
        return self._console

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name in ("_stderr", "_console"):  # copy, pickle: not the console's
            raise AttributeError(name)
        return getattr(self.rich, name)

    def __setattr__(self, name: str, value: Any) -> None:
        if name in ("_stderr", "_console"):
            object.__setattr__(self, name, value)
        else:  # console.width = ...: the console's
            setattr(self.rich, name, value)


console = LazyConsole()
err_console = LazyConsole(stderr=True)

F = TypeVar("F", bound=Callable[..., Any])


def plain(value: object) -> str:
    """``value`` as text to put in a rich markup string: it prints literally.

    Every user-supplied string (file paths, session keys, labels, error messages, method
    names read from files) goes through here before rich sees it, so ``[/x]`` or
    ``[bold]`` in a folder name prints as typed and never raises ``MarkupError``.

    Examples
    --------
    >>> print(plain("runs/[bold]/session.json"))
    runs/\\[bold]/session.json
    """
    from rich.markup import escape

    return escape(str(value))


def print_warning(message: str) -> None:
    """One ``warning:`` line on stderr (the message is user text: printed literally, on one line)."""
    err_console.print(f"[yellow]warning:[/] {plain(one_line(message))}", highlight=False)


def _fit(c: Console) -> None:
    """A wide console when the output is not a terminal (tables and lines stay whole when piped); the terminal's own
    width otherwise."""
    c.width = None  # type: ignore[assignment]  # back to auto-detection, then decide
    if not c.is_terminal:
        c.width = max(c.width, PIPE_WIDTH)


def _fit_consoles() -> None:
    """Fit the consoles made so far to their output as it is now (one made later is fitted then)."""
    for c in (console, err_console):
        if c._console is not None:
            _fit(c._console)


def handle_errors(fn: F) -> F:
    """Turn user errors into a one-line message on stderr and exit code 2."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        _fit_consoles()
        try:
            return fn(*args, **kwargs)
        except InputError as exc:
            _print_error(str(exc))
            raise typer.Exit(2) from None
        except MissingExtra as exc:  # an optional dependency is not installed: the message names the extra
            _print_error(str(exc))
            raise typer.Exit(2) from None
        except TimeLimitExceeded as exc:  # --time-limit expired
            _print_error(str(exc))
            raise typer.Exit(2) from None
        except MemoryError:  # the machine (or a ulimit) ran out
            _print_error("out of memory (MemoryError): give the command less work")
            raise typer.Exit(2) from None
        except OSError as exc:  # file system errors (missing, read-only, disk full, I/O): one line naming the file
            name = exc.filename if exc.filename is not None else "(file)"
            _print_error(f"{name}: {exc.strerror or type(exc).__name__}")
            raise typer.Exit(2) from None

    return wrapper  # type: ignore[return-value]


def _print_error(message: str) -> None:
    err_console.print(f"[bold red]error:[/] {plain(one_line(message))}", highlight=False)


def check_output(output: Path | None, *inputs: Path | None, flag: str = "--output") -> None:
    """Refuse an output path that cannot be written, before any computation.

    The folder must exist and be writable, the path must not be a folder, and it
    must not be one of the ``inputs`` (which it would overwrite); ``flag`` is the option
    that named it, for the message.
    """
    if output is None:
        return
    name = one_line(str(output))
    if output.is_dir():
        raise InputError(f"{name}: is a directory, expected a file to write")
    parent = output.parent if str(output.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{name}: cannot write, folder {one_line(str(parent))} does not exist")
    if output.exists() and not os.access(output, os.W_OK) or not output.exists() and not os.access(parent, os.W_OK):
        raise InputError(f"{name}: cannot write (permission denied)")
    for source in inputs:
        if source is None or not source.exists() or not output.exists():
            continue
        try:
            same = os.path.samefile(source, output)
        except OSError:
            same = False
        if same:
            raise InputError(f"{name}: is also an input file; refusing to overwrite it, choose another {flag}")


@contextlib.contextmanager
def command_budget(time_limit_s: float | None, max_memory: str | None = None) -> Iterator[None]:
    """Run the ``with`` block within ``--time-limit`` seconds and ``--max-memory`` bytes (see :mod:`monovisual3d.budget`)."""
    cap = None
    if max_memory is not None:
        from ..checks import parse_bytes

        cap = parse_bytes(max_memory, "--max-memory")
    with time_limit(time_limit_s, hard_exit=True), memory_limit(cap):
        yield


def json_text(data: object, indent: int = 2) -> str:
    """JSON text with non-finite numbers written as ``null`` (``NaN`` and ``Infinity`` are not JSON)."""

    def clean(v: object) -> object:
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    return json.dumps(clean(data), indent=indent, allow_nan=False)


def write_output(path: Path, text: str) -> None:
    """Write ``text`` to ``path``; a failure (disk full, read-only, I/O error) is a one-line error naming the file."""
    try:
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
    except OSError as exc:
        raise InputError(f"{one_line(str(path))}: cannot write ({exc.strerror or type(exc).__name__})") from None


def _show_warning(message: Any, category: type[Warning], filename: str, lineno: int, file: Any = None, line: Any = None) -> None:
    print_warning(str(message))


def only_command(argv: list[str]) -> typer.Typer:
    """The application to run for ``argv`` (the arguments after the program name): when they name one top-level
    command, an application with that command alone, so that its options are the only ones built (typer builds every
    command's options before it runs one: 0.1 s of each command's start, issue 56); else :data:`app` itself."""
    name = argv[0] if argv else ""
    infos = [c for c in app.registered_commands if (c.name or typer.main.get_command_name(c.callback.__name__)) == name]
    if len(infos) != 1:
        return app
    single = typer.Typer(
        cls=_Commands,
        name=app.info.name,
        help=app.info.help,
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
        rich_markup_mode=None,
    )
    single.registered_commands = infos
    single.registered_callback = app.registered_callback
    return single


def main() -> None:
    """Console-script entry point."""
    from ..kernels.bytecode import cache_imported_bytecode
    from ..kernels.jit import compile_notices

    warnings.showwarning = _show_warning
    try:
        with compile_notices():  # a first run says that it compiles the kernels (on stderr)
            only_command(sys.argv[1:])()
    except KeyboardInterrupt:  # pragma: no cover
        sys.exit(130)
    finally:  # where Python writes no bytecode, the next command would compile this package's modules again
        cache_imported_bytecode()
