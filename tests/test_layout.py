"""The package's layout rules: layers point one way, files and functions stay readable, start-up stays light."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import monovisual3d

PACKAGE = Path(monovisual3d.__file__).parent
MAX_FILE_LINES = 800
MAX_FUNCTION_LINES = 80


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _top_level_imports(path: Path) -> set[str]:
    """monovisual3d modules imported at module level (not inside functions, not under TYPE_CHECKING)."""
    tree = ast.parse(path.read_text())
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.startswith("monovisual3d"):
                if node.module:  # ``from .x import y`` needs x; ``from . import x`` needs only the submodule x
                    out.add(mod)
                out.update(f"{mod}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("monovisual3d"))
    return out


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_no_import_cycles() -> None:
    modules = {_module_name(p): p for p in _sources()}
    graph = {m: {i for i in _top_level_imports(p) if i in modules and i != m} for m, p in modules.items()}
    # a package's __init__ importing its own submodules is how packages work; a submodule importing its
    # package's __init__ back (which imports the submodule) is a cycle
    state: dict[str, int] = {}
    cycles: list[list[str]] = []

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for n in graph[m]:
            if state.get(n) == 1:
                cycles.append(stack[stack.index(n) :] + [n])
            elif n not in state:
                visit(n, stack + [n])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert cycles == [], f"import cycles: {cycles}"


def test_source_files_stay_under_800_lines() -> None:
    long = {str(p.relative_to(PACKAGE)): n for p in _sources() if (n := len(p.read_text().splitlines())) > MAX_FILE_LINES}
    assert long == {}


def _compiled(node: ast.FunctionDef, lines: list[str]) -> bool:
    """Decorated with numba's jit, or marked as compiled on its def line (kernels jitted after definition)."""
    if any("jit" in ast.unparse(d) for d in node.decorator_list):
        return True
    header = " ".join(lines[node.lineno - 1 : node.body[0].lineno - 1])
    return "no cover - jitted" in header or "no cover - compiled" in header


def test_functions_stay_under_80_lines_outside_compiled_kernels() -> None:
    long = {}
    for path in _sources():
        text = path.read_text()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _compiled(node, text.splitlines()):  # type: ignore[arg-type]
                n = node.end_lineno - node.lineno + 1  # type: ignore[operator]
                if n > MAX_FUNCTION_LINES:
                    long[f"{path.relative_to(PACKAGE)}:{node.name}"] = n
    assert long == {}


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
    assert not {"scipy", "numba", "sklearn", "matplotlib", "torch", "mujoco", "cv2"} & {m.split(".")[0] for m in loaded}


def test_version_option() -> None:
    out = subprocess.run([sys.executable, "-m", "monovisual3d.cli", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == f"monovisual3d {monovisual3d.__version__}"
