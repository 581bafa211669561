"""The one-off studies in ``experiments/``: argparse, no script imports another, one README line each, and they run.

An experiment is a script that states a question and its answer (``experiments/README.md``); it imports the library
``monovisual3d`` and third-party packages only, so that a study can be read, run and deleted on its own. The library's
API moves; ``--help`` of every script imports everything it uses, so a renamed function fails here, not months later.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FOLDER = ROOT / "experiments"
SCRIPTS = sorted(FOLDER.glob("*.py"))
#: Every experiment, scripts and shell scripts, by file name.
ENTRIES = sorted(p.name for p in FOLDER.iterdir() if p.suffix in (".py", ".sh"))
#: Runs every script's main block with ``--help`` in one fresh interpreter (the imports, most of the time, shared);
#: ``runpy.run_path`` does not put the script's folder on ``sys.path``, so an import of another script fails here too.
HELP_ALL = """
import contextlib, io, json, runpy, sys
out = {}
for path in sys.argv[1:]:
    sys.argv = [path, "--help"]
    text = io.StringIO()
    try:
        with contextlib.redirect_stdout(text):
            runpy.run_path(path, run_name="__main__")
        code = "returned without exiting"
    except SystemExit as exc:
        code = exc.code
    except Exception as exc:
        code = repr(exc)
    out[path] = [code, "usage:" in text.getvalue()]
print(json.dumps(out))
"""
#: Seconds a script's ``--help`` or quick run may take before the test gives up on it.
TIMEOUT_S = 300


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _imported_modules(tree: ast.Module) -> list[tuple[str, int]]:
    """Top-level names of every module the script imports (and the import's level: relative imports have one)."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name.split(".")[0], 0) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append(((node.module or "").split(".")[0], node.level))
    return out


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=TIMEOUT_S, cwd=ROOT)


def test_there_are_experiments() -> None:
    assert len(SCRIPTS) >= 10 and not (ROOT / "benchmarks").exists()


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_a_script_imports_no_other_script(script: Path) -> None:
    others = {p.stem for p in SCRIPTS}
    imports = _imported_modules(_tree(script))
    assert not [m for m, level in imports if level], f"{script.name}: a relative import"
    assert not [m for m, _ in imports if m in others], f"{script.name} imports another experiment: import from monovisual3d"
    assert "sys.path" not in script.read_text(), f"{script.name}: no sys.path tricks"
    assert "monovisual3d" in {m for m, _ in imports}, f"{script.name}: an experiment of this library imports it"


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_a_script_parses_its_arguments_with_argparse(script: Path) -> None:
    tree = _tree(script)
    assert "argparse" in {m for m, _ in _imported_modules(tree)}, f"{script.name}: parse arguments with argparse"
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and (node.value.id, node.attr) == ("sys", "argv"):
            # the one use allowed: the localize options after --, split off before argparse (bench.option_ab.split_options)
            assert any(
                isinstance(call, ast.Call) and ast.unparse(call.func) == "split_options" and node in ast.walk(call)
                for call in ast.walk(tree)
            ), f"{script.name}:{node.lineno}: sys.argv read by hand; use argparse"


def test_the_readme_has_one_line_per_experiment() -> None:
    lines = [line for line in (FOLDER / "README.md").read_text().splitlines() if line.startswith("- `")]
    named = [re.match(r"- `([\w.]+)`", line).group(1) for line in lines]  # type: ignore[union-attr]
    assert sorted(named) == ENTRIES, "experiments/README.md: one line `- `NAME`: question -> answer (command)` per script"
    for name, line in zip(named, lines):
        runner = "bash" if name.endswith(".sh") else "python"
        assert " -> " in line, f"README line of {name}: question -> answer"
        assert f"`{runner} experiments/{name}" in line, f"README line of {name}: the command that gives the answer"


def test_every_script_answers_help() -> None:
    out = _run("-c", HELP_ALL, *(str(p.relative_to(ROOT)) for p in SCRIPTS))
    assert out.returncode == 0, out.stderr
    runs = json.loads(out.stdout.splitlines()[-1])
    assert sorted(runs) == sorted(str(p.relative_to(ROOT)) for p in SCRIPTS)
    failed = {path: code for path, (code, usage) in runs.items() if code not in (0, None) or not usage}
    assert failed == {}, f"--help failed: {failed}"


def test_a_quick_run_of_the_single_container() -> None:
    out = _run("experiments/single_container.py", "0", "2", "1,0.15", "--", "pose_sigma_mm=1")
    assert out.returncode == 0, out.stderr
    assert re.fullmatch(
        r"cuboid, noise 0.005, pose error 1 mm 0.15 deg, elevation 0-30 deg, seeds 0-1: no object 0/2; "
        r"error mean [\d.]+, p90 [\d.]+, max [\d.]+ mm; beyond 30 mm 0\n",
        out.stdout,
    ), out.stdout


def test_a_quick_run_of_the_hand_eye_fit() -> None:
    out = _run("experiments/hand_eye_bias.py", "10", "1", "0.3", "8", "0", "3")
    assert out.returncode == 0, out.stderr
    lines = dict(line.split(": ", 1) for line in out.stdout.splitlines())
    assert set(lines) == {"plain", "joint"}
    mean = {k: float(v.split()[1]) for k, v in lines.items()}
    assert mean["joint"] < 0.01 < mean["plain"]  # exact projections: the joint fit recovers the hand-eye error


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["experiments/container_pairs.py", "box"], "invalid choice: 'box'"),
        (["experiments/container_pairs.py", "--pose-error=1"], "--pose-error: got '1', expected MM,DEG"),
        (["experiments/tabletop_subsets.py", "810", "813", "--", "second_look"], "expected KEY=VALUE"),
        (["experiments/real_floor.py", "--data", "no-such-folder"], "no-such-folder"),
    ],
)
def test_bad_arguments_are_one_line(args: list[str], message: str) -> None:
    out = _run(*args)
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and "Traceback" not in out.stderr
