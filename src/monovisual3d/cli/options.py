"""CLI options built from the methods' config dataclasses (no hand-kept flag list), and who each one is for.

Every field of every registered method's config (:data:`monovisual3d.methods.METHODS`) is an option of
``localize``, with the help text taken from the config docstring's Attributes section. :data:`USER_OPTIONS` and
:data:`DEVELOPER_GROUPS` decide, in one place, how a user reaches each one:

- **user**: a flag that ``localize --help`` shows, in a named panel (:data:`USER_OPTIONS`);
- **expert**: a flag that ``--help`` hides and ``--help-all`` lists in its method's panel (every other field);
- **developer**: no flag; ``--set NAME=VALUE`` sets it (the fields of an option group named in
  :data:`DEVELOPER_GROUPS`, e.g. ``BayesConfig.tuning``); ``--help-all`` and ``monovisual3d options`` list them.

``--set NAME=VALUE`` reaches every option of the method by name. An option that does not belong to the chosen method
is an error naming the option as typed (``--kernel: ...``, ``--set swap: ...``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import inspect
import json
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..errors import InputError
from ..methods import METHODS, get_method
from .panels import PANEL_FIND, PANEL_LIMITS, PANEL_MORE, PANEL_SCENE, PANEL_SHARED, help_all_parameter, print_table_panels

if TYPE_CHECKING:
    from ..methods import Method

#: The method options a user decides, each a flag shown by ``localize --help`` in this panel: what to look for, the
#: scene and how well its poses are known, what the run may spend. The one place the choice is written (``monovisual3d
#: options`` shows it per option, as ``user``); the command's own options (``--method``, ``--output``, ``--view``,
#: ``--quiet``, ``--strict``, ``--time-limit``) take the same panels. The other fields' defaults are the method (the
#: grid, the sensor model, the paper's kernel and clustering): expert flags, changed with a reason (docs/accuracy.md).
USER_OPTIONS: dict[str, str] = {
    "shape": PANEL_FIND,
    "size_range": PANEL_FIND,
    "accept": PANEL_FIND,
    "reach": PANEL_SCENE,
    "pose_sigma_mm": PANEL_SCENE,
    "pose_sigma_deg": PANEL_SCENE,
    "calibrate": PANEL_SCENE,
    "max_memory": PANEL_LIMITS,
    "threads": PANEL_LIMITS,
}
#: Option groups of a method's config whose fields are developer knobs (ablation switches, search effort): no flag,
#: ``--set NAME=VALUE`` only. Every field outside :data:`USER_OPTIONS` and these groups is an expert flag.
DEVELOPER_GROUPS = ("tuning",)
#: Titles of the option groups in the help panels and tables (``bayes sensor model``).
GROUP_TITLES = {"sensor": "sensor model"}


def audience(name: str, group: str = "") -> str:
    """Who the option ``name`` (a field of the option group ``group``, ``""`` for the config's own) is for: ``user``,
    ``expert`` or ``developer`` (see the module docstring).

    Examples
    --------
    >>> audience("accept"), audience("resolution"), audience("alpha", "sensor"), audience("swap", "tuning")
    ('user', 'expert', 'expert', 'developer')
    """
    if name in USER_OPTIONS:
        return "user"
    return "developer" if group in DEVELOPER_GROUPS else "expert"


def parse_options(items: list[str] | None, flag: str = "--option") -> dict[str, Any]:
    """``KEY=VALUE`` strings (of the option ``flag``) as a dict; a value is read as JSON when it parses (``3``,
    ``0.01``, ``true``), else kept as text.

    Examples
    --------
    >>> parse_options(["resolution=0.01", "kernel=gaussian", "k=3"])
    {'resolution': 0.01, 'kernel': 'gaussian', 'k': 3}
    """
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise InputError(f"{flag}: got {item!r}, expected KEY=VALUE with KEY a method option name")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


@dataclass(frozen=True)
class MethodField:
    """One option of one method: its name, the option group it lives in (``""``: the config's own field), its Python
    type on the command line, its help (plain text) and its default (as text)."""

    name: str
    group: str
    kind: type
    help: str
    default: str

    @property
    def audience(self) -> str:
        return audience(self.name, self.group)


def method_fields(method: Method) -> list[MethodField]:
    """Every option of ``method``: its config's own fields in order, then those of its option groups
    (``BayesConfig.sensor``, ``BayesConfig.tuning``) by their own names, group by group."""
    from ..methods.options import _nested_fields

    cls = method.config_class
    groups = _nested_fields(cls)
    owners = [("", cls, f) for f in dataclasses.fields(cls) if f.name not in groups]
    owners += [(g, sub, f) for g, sub in groups.items() for f in dataclasses.fields(sub)]
    docs = {c: field_docs(c) for c in {cls, *groups.values()}}
    return [
        MethodField(f.name, group, _cli_kind(str(f.type)), docs[owner].get(f.name, ""), _default_text(f))
        for group, owner, f in owners
    ]


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


@dataclass(frozen=True)
class OptionSpec:
    """One option over every method: the config field, its Python type on the command line, help, the methods that
    have it, each one's default (as text) and the option group it lives in there (``""``: the config's own)."""

    name: str
    kind: type
    help: str
    methods: tuple[str, ...]
    defaults: tuple[str, ...] = ()
    groups: tuple[str, ...] = ()

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    @property
    def audience(self) -> str:
        """``user``, ``expert`` or ``developer`` (:func:`audience`): a developer knob only where every method that has
        it keeps it in a developer group."""
        kinds = {audience(self.name, g) for g in self.groups or ("",)}
        return "developer" if kinds == {"developer"} else "user" if "user" in kinds else "expert"

    @property
    def typed(self) -> str:
        """The option as a user types it: its flag, or ``--set NAME`` for a developer knob."""
        return f"--set {self.name}" if self.audience == "developer" else self.flag

    @property
    def panel(self) -> str:
        """The help panel it is listed in: its :data:`USER_OPTIONS` panel; else its method's (``Expert: bayes
        sensor model``, ``Developer knobs: bayes tuning (--set NAME=VALUE)``), or :data:`PANEL_SHARED` when several
        methods have it."""
        if self.audience == "user":
            return USER_OPTIONS[self.name]
        group = self.groups[0] if self.groups else ""
        if self.audience == "developer":
            return f"Developer knobs: {self.methods[0]} {group} (--set NAME=VALUE)"
        if len(self.methods) > 1:
            return PANEL_SHARED
        return f"Expert: {self.methods[0]} " + (GROUP_TITLES.get(group, group) if group else "method")


def option_specs(methods: tuple[str, ...] | None = None) -> list[OptionSpec]:
    """The options of every registered method (or of ``methods``), each once (in registry and :func:`method_fields`
    order)."""
    specs: dict[str, OptionSpec] = {}
    for method in METHODS.values():
        if methods is not None and method.name not in methods:
            continue
        for f in method_fields(method):
            if f.name in specs:
                old = specs[f.name]
                specs[f.name] = dataclasses.replace(
                    old, methods=(*old.methods, method.name), defaults=(*old.defaults, f.default), groups=(*old.groups, f.group)
                )
                continue
            specs[f.name] = OptionSpec(f.name, f.kind, f.help, (method.name,), (f.default,), (f.group,))
    return list(specs.values())


def _help(spec: OptionSpec) -> str:
    who = "" if len(spec.methods) == len(METHODS) else f"{'/'.join(spec.methods)} method: "
    if len(set(spec.defaults)) <= 1:
        default = f" [default: {spec.defaults[0]}]" if spec.defaults else ""
    else:
        default = " [default: " + "; ".join(f"{m} {d}" for m, d in zip(spec.methods, spec.defaults)) + "]"
    return who + spec.help + default  # the help is plain text already (field_docs)


def _parameter(spec: OptionSpec) -> inspect.Parameter:
    """The flag of a user or expert option: shown in its panel, or hidden from ``--help`` (``--help-all`` lists it)."""
    decls = f"{spec.flag}/--no-{spec.flag[2:]}" if spec.kind is bool else spec.flag
    option = typer.Option(decls, help=_help(spec), show_default=False, hidden=spec.audience != "user", rich_help_panel=spec.panel)
    annotation = Annotated[spec.kind | None, option]  # type: ignore[operator]
    return inspect.Parameter(spec.name, inspect.Parameter.KEYWORD_ONLY, default=None, annotation=annotation)


#: ``--set NAME=VALUE`` of the commands with method options: any option of the method by name, developer knobs too.
_SET = inspect.Parameter(
    "set_options",
    inspect.Parameter.KEYWORD_ONLY,
    default=None,
    annotation=Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            metavar="NAME=VALUE",
            help="Set any option of the method by name, the developer knobs too (VALUE read as JSON when it parses, "
            "e.g. --set lookahead=5 --set swap=false); repeatable. `monovisual3d options METHOD` lists them.",
            rich_help_panel=PANEL_MORE,
        ),
    ],
)


def _print_developer_knobs() -> None:
    """The ``--help-all`` panels of the options no flag reaches (``Developer knobs: bayes tuning``): ``--set NAME=``,
    type and help."""
    panels: dict[str, list[tuple[str, str, str]]] = {}
    for spec in option_specs():
        if spec.audience == "developer":
            panels.setdefault(spec.panel, []).append((f"--set {spec.name}=", f"<{spec.kind.__name__}>", _help(spec)))
    print_table_panels(panels)


@dataclass(frozen=True)
class MethodOptions:
    """The method options a command was given: values by option name, and how the user typed each one
    (``--accept``, ``--set swap``), for the errors."""

    values: dict[str, Any]
    typed: dict[str, str]

    @classmethod
    def given(cls, flags: Mapping[str, Any], settings: list[str] | None = None) -> MethodOptions:
        """From the flags' values by name (``None``: not given) and the ``--set NAME=VALUE`` strings; an option given
        both ways is an error."""
        values = {k: v for k, v in flags.items() if v is not None}
        typed = {k: "--" + k.replace("_", "-") for k in values}
        for name, value in parse_options(settings, "--set").items():
            if name in values:
                raise InputError(f"{typed[name]}, --set {name}: give one of them")
            values[name], typed[name] = value, f"--set {name}"
        return cls(values, typed)


def with_method_options(fn: Callable[..., Any] | None = None, *, methods: tuple[str, ...] | None = None) -> Any:
    """Give a command the flags of the methods' user and expert options, ``--set NAME=VALUE`` and ``--help-all``;
    it receives the given ones as ``method_options`` (a :class:`MethodOptions`, for :func:`method_config`).

    ``fn`` must have a ``method_options`` keyword parameter; register it with ``cls=PanelCommand`` so that its
    ``--help`` shows the panels. ``methods``: only these methods' options (``@with_method_options(methods=("bayes",))``);
    by default every registered method's.
    """
    if fn is None:
        return functools.partial(with_method_options, methods=methods)
    order = list(USER_OPTIONS)
    specs = sorted(
        (s for s in option_specs(methods) if s.audience != "developer"),
        key=lambda s: order.index(s.name) if s.name in order else len(order),
    )
    sig = inspect.signature(fn, eval_str=True)
    base = [p for p in sig.parameters.values() if p.name != "method_options"]
    params = base + [_parameter(s) for s in specs] + [_SET, help_all_parameter(_print_developer_knobs)]
    names = {s.name for s in specs}

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        flags = {k: kwargs.pop(k) for k in list(kwargs) if k in names}
        settings = kwargs.pop("set_options", None)
        kwargs.pop("help_all", None)
        return fn(*args, method_options=MethodOptions.given(flags, settings), **kwargs)

    wrapper.__name__, wrapper.__doc__, wrapper.__module__ = fn.__name__, fn.__doc__, fn.__module__
    wrapper.__signature__ = sig.replace(parameters=params)  # type: ignore[attr-defined]
    wrapper.__annotations__ = {p.name: p.annotation for p in params}
    return wrapper


def _convert(spec: OptionSpec, value: Any) -> Any:
    if spec.name == "k" and isinstance(value, str):  # "max|mode|min|last" or a whole number
        return int(value) if value.isascii() and value.isdigit() and len(value) < 10 else value
    return value


def method_config(method: str | None, options: MethodOptions | Mapping[str, Any]) -> Any:
    """The chosen method's config from CLI options (a mapping: flags by name); errors name each option as typed
    (``--accept: ...``, ``--set swap: ...``)."""
    m = get_method(method) if method is None or method in METHODS else None
    if m is None:
        raise InputError(f"--method: got {method!r}, expected one of {sorted(METHODS)}")
    given = options if isinstance(options, MethodOptions) else MethodOptions.given(options)
    specs = {s.name: s for s in option_specs()}
    for name, typed in given.typed.items():
        if name not in specs:
            import difflib

            ours = [s.name for s in specs.values() if m.name in s.methods]
            near = difflib.get_close_matches(name, ours, n=1)
            hint = f"did you mean {near[0]}? " if near else ""
            raise InputError(f"{typed}: not an option of --method {m.name} ({hint}`monovisual3d options {m.name}` lists them)")
        if m.name not in specs[name].methods:
            raise InputError(
                f"{typed}: not an option of --method {m.name} (it applies to --method {', '.join(specs[name].methods)})"
            )
    values = {k: _convert(specs[k], v) for k, v in given.values.items()}
    try:
        return m.make_config(**values)
    except InputError as exc:
        raise InputError(_as_typed(str(exc), given.typed)) from None


def _as_typed(message: str, typed: dict[str, str]) -> str:
    """A config error with the given options named as typed: ``radius_min/radius_max: got ...`` becomes
    ``--radius-min: got ...``; a message that names an option elsewhere gets it in front (``--alpha: alpha must
    be >= 0 ...``).

    Examples
    --------
    >>> _as_typed("swap: got 'x', expected true or false", {"swap": "--set swap"})
    "--set swap: got 'x', expected true or false"
    >>> _as_typed("alpha must be >= 0", {"alpha": "--alpha"})
    '--alpha: alpha must be >= 0'
    """
    field, sep, rest = message.partition(":")
    words = re.split(r"[/, ]+", field.strip())
    names = [n for n in words if n in typed]
    if sep and names and all(re.fullmatch(r"[a-z_][a-z0-9_]*", w) for w in words):
        return f"{' / '.join(typed[n] for n in names)}:{rest}"
    named = [n for n in typed if re.search(rf"\b{n}\b", message)]
    return f"{' / '.join(typed[n] for n in named)}: {message}" if named else message


def translate_error(exc: InputError, source: object | None = None) -> InputError:
    """A library error raised while a method ran, in CLI words: option names as typed, the session file first.

    ``resolution: ... resolution 0.0035 m fits ... max_memory`` becomes
    ``FILE: --resolution: ... --resolution 0.0035 fits ... --max-memory``.
    """
    text = str(exc)
    specs = {s.name: s for s in option_specs()}
    field, sep, rest = text.partition(":")
    if sep and field in specs:
        text = specs[field].typed + ":" + rest
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
