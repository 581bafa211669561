"""CLI options built from the methods' config dataclasses (no hand-kept flag table).

Every field of every registered method's config (:data:`monovisual3d.methods.METHODS`)
becomes one ``--field-name`` option of ``localize`` (and of the commands that
localise), with the help text taken from the config docstring's Attributes
section. An option that does not belong to the chosen method is an error
naming the option as typed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import inspect
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ..methods import METHODS, get_method


@dataclass(frozen=True)
class OptionSpec:
    """One CLI option: the config field, its Python type on the command line, help, the methods that have it, and
    each one's default (its config field's, as text)."""

    name: str
    kind: type
    help: str
    methods: tuple[str, ...]
    defaults: tuple[str, ...] = ()

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


def field_docs(cls: type) -> dict[str, str]:
    """Field name -> description, from the numpydoc ``Attributes`` section of a dataclass docstring."""
    doc = inspect.getdoc(cls) or ""
    section = doc.split("Attributes\n----------\n", 1)[-1] if "Attributes\n" in doc else ""
    out: dict[str, str] = {}
    current: list[str] = []
    for line in section.splitlines():
        m = re.match(r"^([a-z_][a-z0-9_]*(?:, [a-z_][a-z0-9_]*)*) : (.*)$", line)
        if m:
            current = [n.strip() for n in m.group(1).split(",")]
            for n in current:
                out[n] = m.group(2).strip()
        elif line.startswith(" ") and current:
            for n in current:
                out[n] += " " + line.strip()
        elif line.strip() == "" and current:
            continue
        else:
            break
    return {k: plain_doc(_PY_TYPE.sub("", v)) for k, v in out.items()}


#: The Python type that starts a field's description (``float, metres, ...``): ``--help`` shows the option's type.
_PY_TYPE = re.compile(r"^(?:(?:int|float|str|bool|tuple|list|dict|None)(?: or |, | | ))+(?=\S)(?<=, )")


#: A Sphinx role (``:mod:`~.x.y` ``) in a docstring; ``help`` shows only its target's last part.
_ROLE = re.compile(r":(?:mod|func|class|meth|attr|data|obj):`~?\.?([^`]+)`")


def plain_doc(text: str) -> str:
    """Docstring text as ``--help`` shows it: Sphinx roles as their names, reST double backticks as single quotes.

    Examples
    --------
    >>> plain_doc("see :mod:`.shape_swap` and ``accept``")
    "see shape_swap and 'accept'"
    """
    text = _ROLE.sub(lambda m: m.group(1).rsplit(".", 1)[-1], text)
    return re.sub(r"``([^`]+)``", r"'\1'", text)


def _cli_kind(annotation: str) -> type:
    a = annotation.replace(" ", "")
    if a in ("bool",):
        return bool
    if a in ("float", "float|None"):
        return float
    if a in ("int", "int|None"):
        return int
    return str


def option_specs(methods: tuple[str, ...] | None = None) -> list[OptionSpec]:
    """The options of every registered method (or of ``methods``), each once (in registry and field order)."""
    specs: dict[str, OptionSpec] = {}
    for method in METHODS.values():
        if methods is not None and method.name not in methods:
            continue
        cls = method.config_class
        docs = field_docs(cls)
        for f in dataclasses.fields(cls):
            default = _default_text(f)
            if f.name in specs:
                old = specs[f.name]
                specs[f.name] = dataclasses.replace(old, methods=old.methods + (method.name,), defaults=old.defaults + (default,))
                continue
            specs[f.name] = OptionSpec(f.name, _cli_kind(str(f.type)), docs.get(f.name, ""), (method.name,), (default,))
    return list(specs.values())


def _default_text(f: dataclasses.Field) -> str:  # type: ignore[type-arg]
    """A config field's default as ``--help`` shows it: ``none``, ``on``/``off``, numbers as typed, tuples with commas."""
    v = f.default_factory() if f.default is dataclasses.MISSING and f.default_factory is not dataclasses.MISSING else f.default
    if v is None or v is dataclasses.MISSING:
        return "none"
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, int) and v >= 2**20 and v % 2**20 == 0:  # a memory size
        return f"{v / 2**30:g}GiB" if v % 2**30 == 0 else f"{v / 2**20:g}MiB"
    if isinstance(v, tuple | list):
        return ",".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v)
    return f"{v:g}" if isinstance(v, float) else str(v)


def _help(spec: OptionSpec) -> str:
    who = "" if len(spec.methods) == len(METHODS) else f"{'/'.join(spec.methods)} method: "
    if len(set(spec.defaults)) <= 1:
        default = f" [default: {spec.defaults[0]}]" if spec.defaults else ""
    else:
        default = " [default: " + "; ".join(f"{m} {d}" for m, d in zip(spec.methods, spec.defaults)) + "]"
    return who + spec.help + default  # the help is plain text already (field_docs)


def _parameter(spec: OptionSpec) -> inspect.Parameter:
    if spec.kind is bool:
        option = typer.Option(f"{spec.flag}/--no-{spec.flag[2:]}", help=_help(spec), show_default=False)
    else:
        option = typer.Option(spec.flag, help=_help(spec), show_default=False)
    annotation = Annotated[spec.kind | None, option]  # type: ignore[operator]
    return inspect.Parameter(spec.name, inspect.Parameter.KEYWORD_ONLY, default=None, annotation=annotation)


def _convert(spec: OptionSpec, value: Any) -> Any:
    if spec.name == "k" and isinstance(value, str):  # "max|mode|min|last" or a whole number
        return int(value) if value.isascii() and value.isdigit() and len(value) < 10 else value
    return value


def with_method_options(fn: Callable[..., Any] | None = None, *, methods: tuple[str, ...] | None = None) -> Any:
    """Give a command one option per method config field; it receives them as ``method_options`` (given ones only).

    ``fn`` must have a ``method_options: dict`` keyword parameter. ``methods``: only these methods' fields (used as
    ``@with_method_options(methods=("bayes",))``); by default every registered method's.
    """
    if fn is None:
        return functools.partial(with_method_options, methods=methods)
    specs = option_specs(methods)
    sig = inspect.signature(fn, eval_str=True)
    base = [p for p in sig.parameters.values() if p.name != "method_options"]
    params = base + [_parameter(s) for s in specs]
    names = {s.name for s in specs}

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        given = {k: kwargs.pop(k) for k in list(kwargs) if k in names}
        return fn(*args, method_options={k: v for k, v in given.items() if v is not None}, **kwargs)

    wrapper.__name__, wrapper.__doc__, wrapper.__module__ = fn.__name__, fn.__doc__, fn.__module__
    wrapper.__signature__ = sig.replace(parameters=params)  # type: ignore[attr-defined]
    wrapper.__annotations__ = {p.name: p.annotation for p in params}
    return wrapper


def method_config(method: str | None, options: dict[str, Any]) -> Any:
    """The chosen method's config from CLI options; errors name the option as typed (``--accept: ...``)."""
    m = get_method(method) if method is None or method in METHODS else None
    if m is None:
        raise InputError(f"--method: got {method!r}, expected one of {sorted(METHODS)}")
    specs = {s.name: s for s in option_specs()}
    for name in options:
        if m.name not in specs[name].methods:
            raise InputError(
                f"{specs[name].flag}: not an option of --method {m.name} (it applies to --method {', '.join(specs[name].methods)})"
            )
    values = {k: _convert(specs[k], v) for k, v in options.items()}
    try:
        return m.make_config(**values)
    except InputError as exc:
        field, _, rest = str(exc).partition(":")
        names = [n for n in re.split(r"[/, ]+", field) if n in values]
        if names:
            raise InputError(f"{' / '.join(specs[n].flag for n in names)}:{rest}") from None
        raise


def translate_error(exc: InputError, source: object | None = None) -> InputError:
    """A library error raised while a method ran, in CLI words: option names as flags, the session file first.

    ``resolution: ... resolution 0.0035 m fits ... max_memory`` becomes
    ``FILE: --resolution: ... --resolution 0.0035 fits ... --max-memory``.
    """
    text = str(exc)
    specs = {s.name: s for s in option_specs()}
    field, sep, rest = text.partition(":")
    if sep and field in specs:
        text = specs[field].flag + ":" + rest
    text = re.sub(r"\bresolution ([0-9.e+-]+) m fits", r"--resolution \1 fits", text)
    text = re.sub(r"\bmax_memory\b", "--max-memory", text)
    if source is not None and not text.startswith(f"{source}:"):
        text = f"{source}: {text}"
    return InputError(text)


#: ``--workers`` of the commands that spread their runs over Dask (``bench accuracy``, ``bench active``, ``bench real``,
#: ``reproduce``).
SpreadWorkers = Annotated[
    int | None,
    typer.Option(
        "--workers",
        min=0,
        help="Spread the runs (seeds, view subsets) over a local Dask cluster of this many processes (needs the dask extra; "
        "default: here).",
    ),
]
#: ``--scheduler`` of the same commands.
SpreadScheduler = Annotated[
    str | None, typer.Option("--scheduler", help="Spread the runs over a running Dask cluster, e.g. tcp://host:8786.")
]


def spread_flags(workers: int | None, scheduler: str | None) -> contextlib.AbstractContextManager[None]:
    """Check ``--workers``/``--scheduler`` before any work, and name the flags in the errors raised inside
    (``scheduler: cannot connect ...`` becomes ``--scheduler: cannot connect ...``)."""
    if workers is not None and scheduler is not None:
        raise InputError("--workers, --scheduler: give at most one of them")
    return _flag_errors()


@contextlib.contextmanager
def _flag_errors() -> Iterator[None]:
    try:
        yield
    except InputError as exc:
        message = str(exc)
        for name in ("workers", "scheduler"):
            if message.startswith(f"{name}:"):
                raise InputError(f"--{message}") from None
        raise


#: ``--time-limit`` of every command that does work (see :mod:`monovisual3d.budget`).
TimeLimit = Annotated[
    float | None,
    typer.Option(
        "--time-limit",
        help="Stop with an error after this many seconds (default: no limit).",
    ),
]
#: ``--time-limit`` of ``batch``: the same, and what a stopped batch keeps.
BatchTimeLimit = Annotated[
    float | None,
    typer.Option(
        "--time-limit",
        help="Stop with an error after this many seconds (default: no limit); the batch keeps the rows it has written.",
    ),
]
#: ``--max-memory`` of the commands without a method option of that name: a cap on the memory the command adds.
MaxMemory = Annotated[
    str | None,
    typer.Option("--max-memory", help="Memory the command may add, e.g. 2GiB (default: no cap); beyond it, an error."),
]
#: ``--image-size`` of ``import-lfd`` and ``bench real``: the LfD layout has no image size (``io.lfd``).
LfdImageSize = Annotated[
    str | None,
    typer.Option(
        "--image-size", help="Image size WxH (default: the common size nearest twice the principal point that holds the boxes)."
    ),
]
#: ``--output`` of the benchmarks: where their JSON results go.
ResultsOutput = Annotated[
    Path | None, typer.Option("--output", "-o", help="Write the results (with machine metadata) as JSON here.")
]
