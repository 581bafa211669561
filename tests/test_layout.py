"""The package's layout rules: layers point one way, no cycles, files and functions stay readable, start-up stays light.

:data:`LAYERS` is the one written-down layer order; ``docs/architecture.md`` shows the same table
(:func:`test_architecture_doc_shows_the_layers` checks they agree). Imports are read with the AST, all of
them: at module level, inside functions (lazy imports), under ``TYPE_CHECKING``, and the ``"module:name"``
strings of the method registry. A lazy import hides a cycle, it does not remove it.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from pathlib import Path

import monovisual3d

PACKAGE = Path(monovisual3d.__file__).parent
ROOT = PACKAGE.parent.parent
PACKAGE_NAME = "monovisual3d"

#: The layers, bottom first. A module may import modules of its own layer and of the layers below, never above.
#: Each entry names modules relative to the package; a name covers a module and, for a package, everything
#: in it. ``""`` is the package itself (``import monovisual3d``: the public names, loaded on first use).
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "core",
        (
            "_extras",
            "_structured",
            "budget",
            "camera",
            "checks",
            "completeness",
            "errors",
            "examples",
            "file_kinds",
            "frames",
            "grid",
            "limits",
            "masks",
            "metrics",
            "result",
            "session",
            "truth",
            "verdict",
        ),
    ),
    ("geometry", ("geometry",)),
    ("kernels", ("kernels",)),
    ("methods", ("methods", "api", "")),
    ("sim/io/figures", ("sim", "io", "vision", "figures", "rerun_log")),
    ("apps", ("active", "batch", "bench", "experiments", "ros2")),
    ("cli", ("cli",)),
)

#: Rules on top of the layers, each with what to do when it breaks. Names are relative to the package, as in
#: :data:`LAYERS`: a name covers a module and, for a package, everything in it.
#:
#: Packages that import nothing above a layer, whatever :data:`LAYERS` says of their modules:
#: ``(package, highest layer it may import, what to do instead)``.
IMPORTS_UP_TO: tuple[tuple[str, str, str], ...] = (
    (
        "session",
        "core",
        "the session and its loader are the core's input contract: move what they need into the core "
        "(as session/baseline.py), or move the call up to the caller that has that layer (api, cli)",
    ),
)
#: Packages that never import these, even where the layers would allow it: ``(package, names, what to do instead)``.
IMPORTS_NONE_OF: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "io",
        ("methods", "api"),
        "io turns files into sessions and runs no method: move the algebra it needs into geometry/ or the core "
        "(as geometry/quadric.ellipsoid_from_dual_quadric)",
    ),
)
#: Packages whose sub-packages own their parts: a module of ``package.a`` imports no module of ``package.b``
#: (a != b) but the shared modules named: ``(package, shared modules, what to do instead)``.
SIBLINGS_APART: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "methods",
        ("methods", "methods.options"),
        "a method imports no other method: run another method through the registry "
        "(monovisual3d.methods.get_method(name).make_config(...) / .run(session, config)), and move what several "
        "methods use to methods/options.py or a lower layer (kernels/, geometry/, the core)",
    ),
)

#: Largest source file, lines.
MAX_FILE_LINES = 600
#: Largest function outside compiled kernels, lines, unless its docstring says why it is one unit of thought.
MAX_FUNCTION_LINES = 60
#: The phrase that starts that reason in the docstring, e.g. ``One unit of thought: the steps share ...``.
WHOLE_MARKER = "One unit of thought:"

# TEMPORARY (issue 19): files and functions still over the limits on this branch that other helpers are
# splitting right now (viz/viz3d -> figures/, active/planner, bench/speed, io/calibration, geometry/ellipsoid),
# and the long functions outside the files this branch owns. Empty these lists as the splits land; the
# tests below also fail when an entry is no longer needed, so the lists can only shrink.
ALLOWED_LONG_FILES: set[str] = set()
ALLOWED_LONG_FUNCTIONS = {
    "methods/bayes/_kernels.py:score_hypotheses",
    "geometry/fit.py:fit_ellipsoid_to_boxes",
}
#: TEMPORARY (issue 19): import cycles being removed on other branches (camera <-> session; sim.simulate <-> viz),
#: each as the sorted tuple of the modules on the cycle. Empty it once those branches are merged.
ALLOWED_CYCLES: set[tuple[str, ...]] = set()

#: A registry string such as ``"monovisual3d.methods.bayes.config:BayesConfig"`` imports that module on first use.
_MODULE_STRING = re.compile(rf"{PACKAGE_NAME}(\.\w+)+(:\w+)?")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


MODULES = {_module_name(p): p for p in _sources()}


def _lazy_names() -> dict[str, str]:
    """The package's public names and the modules that define them (``_LAZY`` of ``monovisual3d/__init__.py``)."""
    for node in ast.parse((PACKAGE / "__init__.py").read_text()).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "_LAZY" for t in node.targets):
            return {k: f"{PACKAGE_NAME}.{v}" for k, v in ast.literal_eval(node.value).items()}
    return {}


LAZY_NAMES = _lazy_names()


def _imported_names(path: Path) -> set[str]:
    """Every ``monovisual3d`` module or ``module.name`` this file imports, wherever the import sits."""
    return _names_in(path.read_text(), _module_name(path), is_package=path.name == "__init__.py")


def _names_in(source: str, name: str, *, is_package: bool) -> set[str]:
    """:func:`_imported_names` of the source of module ``name``.

    A public name taken from the package itself (``from monovisual3d import localize``) counts as an
    import of the module that defines it.
    """
    package = name if is_package else name.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                mod = ".".join(base[: len(base) - node.level + 1] + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod == PACKAGE_NAME:
                out.update(LAZY_NAMES.get(a.name, f"{mod}.{a.name}") for a in node.names)
            elif mod.split(".")[0] == PACKAGE_NAME:
                if node.module:  # ``from .x import y`` needs x; ``from . import x`` needs only the submodule x
                    out.add(mod)
                out.update(f"{mod}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == PACKAGE_NAME)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and _MODULE_STRING.fullmatch(node.value):
            out.add(node.value.split(":")[0])
    return out


def _imports(module: str) -> set[str]:
    """The package's modules that importing ``module`` runs: each imported module and its parent packages.

    The package root and ``module``'s own parent packages are left out: they are already being imported
    when ``module`` runs (that a package's ``__init__`` imports its submodules is how packages work).
    """
    own = {".".join(module.split(".")[:i]) for i in range(1, module.count(".") + 1)}
    out: set[str] = set()
    for name in _imported_names(MODULES[module]):
        parts = name.split(".")
        for i in range(1 if name == PACKAGE_NAME else 2, len(parts) + 1):  # ``import monovisual3d``: its public names
            mod = ".".join(parts[:i])
            if mod in MODULES and mod not in own and mod != module:
                out.add(mod)
    return out


GRAPH = {m: _imports(m) for m in MODULES}


def _layer(module: str) -> int:
    """Index in :data:`LAYERS` of a module (its longest matching name)."""
    rel = module[len(PACKAGE_NAME) + 1 :] if module != PACKAGE_NAME else ""
    best, best_len = -1, -1
    for i, (_, names) in enumerate(LAYERS):
        for n in names:
            if (n == "" and rel == "") or (n and (rel == n or rel.startswith(n + "."))):
                if len(n) > best_len:
                    best, best_len = i, len(n)
    return best


def _cycles() -> set[tuple[str, ...]]:
    """The strongly connected components (Tarjan) with more than one module, each as a sorted tuple."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: set[tuple[str, ...]] = set()

    def visit(m: str) -> None:
        index[m] = low[m] = len(index)
        stack.append(m)
        on_stack.add(m)
        for n in sorted(GRAPH[m]):
            if n not in index:
                visit(n)
                low[m] = min(low[m], low[n])
            elif n in on_stack:
                low[m] = min(low[m], index[n])
        if low[m] == index[m]:
            component = []
            while True:
                n = stack.pop()
                on_stack.discard(n)
                component.append(n)
                if n == m:
                    break
            if len(component) > 1:
                out.add(tuple(sorted(component)))

    for m in sorted(GRAPH):
        if m not in index:
            visit(m)
    return out


def test_every_module_has_a_layer() -> None:
    missing = sorted(m for m in MODULES if _layer(m) < 0)
    assert missing == [], f"add these modules to LAYERS in tests/test_layout.py (and docs/architecture.md): {missing}"


def test_no_import_points_up_a_layer() -> None:
    up = sorted(
        f"{m} ({LAYERS[_layer(m)][0]}) imports {n} ({LAYERS[_layer(n)][0]})"
        for m, imported in GRAPH.items()
        for n in imported
        if _layer(n) > _layer(m)
    )
    assert up == [], "imports up a layer:\n" + "\n".join(up)


def test_the_core_imports_no_upper_package() -> None:
    """Spelled out for the core: nothing of methods, kernels, sim, io, the figures or the applications."""
    upper = ("methods", "kernels", "sim", "io", "cli", "batch", "active", "bench", "experiments", "figures", "ros2")
    bad = sorted(
        f"{m} imports {n}" for m, imported in GRAPH.items() if _layer(m) == 0 for n in imported if n.split(".")[1] in upper
    )
    assert bad == [], "the core imports an upper package:\n" + "\n".join(bad)


def _rel(module: str) -> str:
    """A module's name relative to the package (``""`` for the package itself)."""
    return module[len(PACKAGE_NAME) + 1 :] if module != PACKAGE_NAME else ""


def _covers(name: str, module: str) -> bool:
    """Whether ``name`` (relative, as in :data:`LAYERS`) is ``module`` or a package holding it."""
    rel = _rel(module)
    return rel == name or (name != "" and rel.startswith(name + "."))


def _layer_named(name: str) -> int:
    return [n for n, _ in LAYERS].index(name)


def _capped_imports(graph: dict[str, set[str]]) -> list[str]:
    """Breaks of :data:`IMPORTS_UP_TO` in an import graph, one line each."""
    return sorted(
        f"{m} imports {n} ({LAYERS[_layer(n)][0]}): {package} imports nothing above {top}; {todo}"
        for package, top, todo in IMPORTS_UP_TO
        for m, imported in graph.items()
        if _covers(package, m)
        for n in imported
        if _layer(n) > _layer_named(top)
    )


def _banned_imports(graph: dict[str, set[str]]) -> list[str]:
    """Breaks of :data:`IMPORTS_NONE_OF` in an import graph, one line each."""
    return sorted(
        f"{m} imports {n}: {package} imports none of {list(banned)}; {todo}"
        for package, banned, todo in IMPORTS_NONE_OF
        for m, imported in graph.items()
        if _covers(package, m)
        for n in imported
        if any(_covers(b, n) for b in banned)
    )


def _sibling_imports(graph: dict[str, set[str]]) -> list[str]:
    """Breaks of :data:`SIBLINGS_APART` in an import graph, one line each."""

    def part(package: str, module: str) -> str | None:
        """The sub-package (or module) of ``package`` that holds ``module``; None outside it."""
        rel = _rel(module)
        return rel.split(".")[package.count(".") + 1] if _covers(package, module) and rel != package else None

    return sorted(
        f"{m} imports {n}: {package}.{part(package, m)} and {package}.{part(package, n)} own their parts; {todo}"
        for package, shared, todo in SIBLINGS_APART
        for m, imported in graph.items()
        if part(package, m) is not None and not any(_rel(m) == s for s in shared)
        for n in imported
        if part(package, n) not in (None, part(package, m)) and not any(_rel(n) == s for s in shared)
    )


def test_packages_held_below_their_layer() -> None:
    """The session package imports only the core (:data:`IMPORTS_UP_TO`)."""
    bad = _capped_imports(GRAPH)
    assert bad == [], "imports above a package's cap (IMPORTS_UP_TO in tests/test_layout.py):\n" + "\n".join(bad)


def test_packages_import_none_of_their_banned_names() -> None:
    """io imports no method (:data:`IMPORTS_NONE_OF`)."""
    bad = _banned_imports(GRAPH)
    assert bad == [], "banned imports (IMPORTS_NONE_OF in tests/test_layout.py):\n" + "\n".join(bad)


def test_methods_own_their_parts() -> None:
    """No module of ``methods/X`` imports ``methods/Y`` (:data:`SIBLINGS_APART`); the registry and options are shared."""
    bad = _sibling_imports(GRAPH)
    assert bad == [], "imports between sibling packages (SIBLINGS_APART in tests/test_layout.py):\n" + "\n".join(bad)


def test_the_rules_catch_what_they_forbid() -> None:
    """Each rule, on an import graph that breaks it (the imports this package had before they were removed)."""
    graph = {
        "monovisual3d.session.load": {"monovisual3d.geometry.baseline", "monovisual3d.camera"},
        "monovisual3d.io.lfd": {"monovisual3d.methods.quadric.dual", "monovisual3d.geometry.quadric"},
        "monovisual3d.methods.quadric.localizer": {
            "monovisual3d.methods.bayes.localizer",
            "monovisual3d.methods.quadric.dual",
            "monovisual3d.methods",
            "monovisual3d.methods.options",
        },
        "monovisual3d.methods": {"monovisual3d.methods.bayes.localizer", "monovisual3d.methods.quadric.localizer"},
    }
    (capped,) = _capped_imports(graph)
    assert capped.startswith("monovisual3d.session.load imports monovisual3d.geometry.baseline (geometry): session")
    (banned,) = _banned_imports(graph)
    assert banned.startswith("monovisual3d.io.lfd imports monovisual3d.methods.quadric.dual: io imports none of")
    (sibling,) = _sibling_imports(graph)
    assert sibling.startswith(
        "monovisual3d.methods.quadric.localizer imports monovisual3d.methods.bayes.localizer: "
        "methods.quadric and methods.bayes own their parts"
    )


def test_no_import_cycles() -> None:
    cycles = _cycles()
    new = sorted(cycles - ALLOWED_CYCLES)
    assert new == [], "import cycles (lazy and TYPE_CHECKING imports included):\n" + "\n".join(" <-> ".join(c) for c in new)
    assert sorted(ALLOWED_CYCLES - cycles) == [], "these cycles are gone: remove them from ALLOWED_CYCLES"


def test_the_import_graph_sees_lazy_imports() -> None:
    """The checks above read imports inside functions and the registry's strings (a module-level-only scan would not)."""
    assert "monovisual3d.methods.paper.engine.dense" in GRAPH["monovisual3d.methods.paper.engine"]  # imported inside a function
    assert "monovisual3d.methods.paper.run" in GRAPH["monovisual3d.methods"]  # a "module:function" registry string
    assert "monovisual3d.methods.paper.filter" in GRAPH["monovisual3d"]  # under TYPE_CHECKING


def test_a_public_name_counts_as_its_module() -> None:
    """``from monovisual3d import localize`` (or ``from . import localize``) imports ``monovisual3d.api``."""
    source = "def f():\n    from . import localize\n    from monovisual3d import Camera\n"
    assert _names_in(source, "monovisual3d.grid", is_package=False) == {"monovisual3d.api", "monovisual3d.camera"}


def test_source_files_stay_under_the_line_limit() -> None:
    lines = {str(p.relative_to(PACKAGE)): len(p.read_text().splitlines()) for p in _sources()}
    long = {f: n for f, n in lines.items() if n > MAX_FILE_LINES}
    assert sorted(set(long) - ALLOWED_LONG_FILES) == [], f"files over {MAX_FILE_LINES} lines: {long}"
    assert sorted(ALLOWED_LONG_FILES - set(long)) == [], "these files are short now: remove them from ALLOWED_LONG_FILES"


def _compiled(node: ast.FunctionDef, lines: list[str]) -> bool:
    """Decorated with numba's jit, or marked as compiled on its def line (kernels jitted after definition)."""
    if any("jit" in ast.unparse(d) for d in node.decorator_list):
        return True
    header = " ".join(lines[node.lineno - 1 : node.body[0].lineno - 1])
    return "no cover - jitted" in header or "no cover - compiled" in header


def _says_why(node: ast.FunctionDef) -> bool:
    """The docstring gives a reason after :data:`WHOLE_MARKER` (a few words at least)."""
    doc = ast.get_docstring(node) or ""
    return WHOLE_MARKER in doc and len(doc.split(WHOLE_MARKER, 1)[1].split()) >= 5


def _long_functions() -> dict[str, int]:
    long = {}
    for path in _sources():
        text = path.read_text()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _compiled(node, text.splitlines()):  # type: ignore[arg-type]
                n = node.end_lineno - node.lineno + 1  # type: ignore[operator]
                if n > MAX_FUNCTION_LINES and not _says_why(node):  # type: ignore[arg-type]
                    long[f"{path.relative_to(PACKAGE)}:{node.name}"] = n
    return long


def test_long_functions_say_why_they_are_one_unit() -> None:
    long = _long_functions()
    assert sorted(set(long) - ALLOWED_LONG_FUNCTIONS) == [], (
        f"functions over {MAX_FUNCTION_LINES} lines: split them by concept, or say why in the docstring "
        f"({WHOLE_MARKER!r} and the reason): { {k: v for k, v in long.items() if k not in ALLOWED_LONG_FUNCTIONS} }"
    )
    assert sorted(ALLOWED_LONG_FUNCTIONS - set(long)) == [], "these are short now: remove them from ALLOWED_LONG_FUNCTIONS"


def test_architecture_doc_shows_the_layers() -> None:
    """``docs/architecture.md`` lists the layers of :data:`LAYERS`, in the same order, top first."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    rows = re.findall(r"^\| (\d) \| ([^|]+) \|", text, flags=re.M)
    assert [name.strip() for _, name in sorted(rows, key=lambda r: -int(r[0]))] == [n for n, _ in reversed(LAYERS)]


def _modules_after(code: str) -> set[str]:
    out = subprocess.run(
        [sys.executable, "-c", f"{code}\nimport sys\nprint(' '.join(sys.modules))"], capture_output=True, text=True, check=True
    )
    return set(out.stdout.split())


def test_import_is_light() -> None:
    loaded = _modules_after("import monovisual3d")
    assert not {"numpy", "scipy", "numba", "sklearn", "matplotlib", "typer"} & loaded


def test_cli_help_does_not_load_the_heavy_libraries() -> None:
    loaded = _modules_after("from monovisual3d.cli import app\nimport typer\ntyper.main.get_command(app)")
    assert not {"numpy", "scipy", "numba", "sklearn", "matplotlib", "torch", "mujoco", "cv2"} & {m.split(".")[0] for m in loaded}


def test_localize_path_loads_no_unused_scipy() -> None:
    """The default method's modules and the session loader import neither scipy.optimize (0.45 s), scipy.spatial nor
    scipy.special: the few calls that need them (pose corrections, bounded shape fits) import them on first use
    (issue 56)."""
    loaded = _modules_after(
        "import monovisual3d.api, monovisual3d.session.load, monovisual3d.methods.bayes.pipeline, monovisual3d.cli"
    )
    assert "monovisual3d.methods.bayes.pipeline" in loaded
    assert not {"scipy.optimize", "scipy.spatial", "scipy.special"} & loaded


def test_a_command_line_naming_a_command_imports_that_commands_module_alone(tmp_path: Path) -> None:
    """``monovisual3d localize`` on a JSON session imports the module of ``localize`` and none of the other commands',
    nor rich (``-q`` prints nothing): their imports are 0.06 s of each command's start (issue 56)."""
    from monovisual3d.examples import example_session_path

    argv = ["monovisual3d", "localize", str(example_session_path()), "-q", "-o", str(tmp_path / "out.json")]
    loaded = _modules_after(
        f"import sys\nsys.argv = {argv!r}\nfrom monovisual3d.cli import main\ntry:\n    main()\nexcept SystemExit:\n    pass"
    )
    assert (tmp_path / "out.json").is_file()
    assert {m for m in loaded if m.startswith("monovisual3d.cli.")} == {
        "monovisual3d.cli._app",
        "monovisual3d.cli.core",
        "monovisual3d.cli.options",
        "monovisual3d.cli.panels",
    }
    assert not {m for m in loaded if m.split(".")[0] == "rich"}  # rich waits for something to print: -q prints nothing


def test_each_listed_command_is_registered_by_its_listed_module() -> None:
    """Importing the command modules one at a time in a fresh process, each top-level command and group appears with
    the module :data:`monovisual3d.cli.COMMAND_MODULES` lists for it, except the ``bench`` group, whose commands
    several modules register (a command line naming it imports them all)."""
    code = """
import json
from monovisual3d import cli
from monovisual3d.cli import _app
import typer

def names():
    commands = {c.name or typer.main.get_command_name(c.callback.__name__) for c in _app.app.registered_commands}
    return commands | {g.name for g in _app.app.registered_groups}

def bench_commands():
    from monovisual3d.cli.bench import bench_app
    return {c.name for c in bench_app.registered_commands}

found, bench_from = {}, set()
for module in cli.MODULES:
    before, bench_before = names(), bench_commands() if "monovisual3d.cli.bench" in __import__("sys").modules else set()
    cli.load_commands((module,))
    found.update({name: module for name in names() - before})
    if bench_commands() - bench_before:
        bench_from.add(module)
print(json.dumps({"found": found, "bench_from": sorted(bench_from)}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    data = json.loads(out.stdout.strip().splitlines()[-1])
    from monovisual3d.cli import COMMAND_MODULES

    assert data["found"].pop("bench") == "accuracy"  # the first module imported registers the group (via cli.bench)
    assert data["found"] == COMMAND_MODULES
    assert len(data["bench_from"]) > 1


def test_every_module_that_registers_commands_is_listed() -> None:
    """A command module left out of :data:`monovisual3d.cli.MODULES` would never be imported: its commands would
    vanish from the application without an error."""
    from monovisual3d.cli import MODULES

    registering = {
        path.stem
        for path in (PACKAGE / "cli").glob("*.py")
        if re.search(r"^@\w+\.command\(|\.add_typer\(", path.read_text(encoding="utf-8"), re.M)
    }
    assert registering == set(MODULES)


def test_version_option() -> None:
    out = subprocess.run([sys.executable, "-m", "monovisual3d.cli", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == f"monovisual3d {monovisual3d.__version__}"
