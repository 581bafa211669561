"""The figures sit beside sim/io: they may use the core, methods and sim, never the CLI; nothing below them imports them."""

from __future__ import annotations

import ast
from pathlib import Path

import monovisual3d

PACKAGE = Path(monovisual3d.__file__).parent
#: Packages and modules that must never import the figures, lazily or not (the simulator among them).
BELOW = ("sim", "methods", "kernels", "geometry", "io", "camera.py", "session", "result.py", "grid.py", "metrics.py")


def imports_of(text: str, package: tuple[str, ...]) -> set[str]:
    """Absolute names of every module the source ``text`` of a module in ``package`` imports, lazily or not."""
    names = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = list(package[: len(package) - node.level + 1]) if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            names.add(module)
            names.update(f"{module}.{a.name}" for a in node.names)
    return names


def imported_modules(path: Path) -> set[str]:
    """:func:`imports_of` a file of the package."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return imports_of(path.read_text(), parts[:-1])


def test_figures_never_import_the_cli() -> None:
    files = sorted((PACKAGE / "figures").rglob("*.py"))
    assert len(files) > 10
    for f in files:
        bad = [m for m in imported_modules(f) if m.startswith("monovisual3d.cli")]
        assert not bad, f"{f.relative_to(PACKAGE)} imports {bad}"


def test_nothing_below_the_figures_imports_them() -> None:
    files = [f for b in BELOW for f in ((PACKAGE / b).rglob("*.py") if (PACKAGE / b).is_dir() else [PACKAGE / b])]
    assert any(f.name == "simulate.py" for f in files)
    for f in files:
        bad = [m for m in imported_modules(f) if m.startswith("monovisual3d.figures")]
        assert not bad, f"{f.relative_to(PACKAGE)} imports {bad}"


def test_the_import_reader_sees_lazy_relative_imports() -> None:
    """The checks can fail: a function-level relative import of the figures (or of the CLI) is found."""
    text = "def f():\n    from ..figures.views import write_view_picture\n    from ..cli import app\n"
    names = imports_of(text, ("monovisual3d", "sim"))
    assert "monovisual3d.figures.views" in names and "monovisual3d.cli" in names
