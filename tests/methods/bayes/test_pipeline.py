"""The ``bayes`` pipeline reads as its algorithm: one ordered list of passes, side by side, over one state."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np

import monovisual3d as mv
from monovisual3d.methods.bayes import pipeline
from monovisual3d.methods.bayes.state import Found, State

PACKAGE = Path(pipeline.__file__).parent
ROOT = PACKAGE.parents[3]
#: The longest chain of imports among the package's modules (its ``__init__`` imports names lazily only).
MAX_IMPORT_DEPTH = 7


def _imports() -> dict[str, set[str]]:
    """Module -> the package's modules it imports (every import: module level, in functions, for type checkers)."""
    names = {p.stem for p in PACKAGE.glob("*.py")} - {"__init__"}
    out = {}
    for name in names:
        found = set()
        for node in ast.walk(ast.parse((PACKAGE / f"{name}.py").read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                found |= {node.module.split(".")[0]} if node.module else {a.name for a in node.names}
        out[name] = found & names - {name}
    return out


def _depth(module: str, graph: dict[str, set[str]], seen: tuple[str, ...] = ()) -> int:
    return max((1 + _depth(m, graph, (*seen, module)) for m in graph[module] if m not in seen), default=0)


def test_the_docstring_lists_the_passes_in_order() -> None:
    listed = re.sub(r"\s+", " ", pipeline.__doc__)
    assert re.sub(r"\s+", " ", pipeline.describe_passes()) in listed


def test_the_architecture_doc_lists_the_passes_in_order() -> None:
    doc = re.sub(r"\s+", " ", (ROOT / "docs" / "architecture.md").read_text())
    assert re.sub(r"\s+", " ", pipeline.describe_passes()) in doc


def test_passes_sit_side_by_side_and_the_chain_stays_short() -> None:
    graph = _imports()
    passes = {p.run.__module__.rsplit(".", 1)[1] for p in pipeline.PASSES}
    assert len(passes) == len(pipeline.PASSES)  # every pass in a module of its own
    for name in passes:
        assert not graph[name] & passes, f"{name} imports another pass: {graph[name] & passes}; move the shared part below"
    assert _depth("localizer", graph) <= MAX_IMPORT_DEPTH


def test_every_switch_of_a_pass_is_a_tuning_field() -> None:
    from monovisual3d.methods.bayes.config import SWITCHES, BayesTuning

    switches = {p.switch for p in pipeline.PASSES if p.switch}
    assert switches <= set(SWITCHES) and all(hasattr(BayesTuning(), s) for s in switches)


def test_a_switched_off_pass_does_not_run_and_every_pass_has_a_time() -> None:
    from monovisual3d.examples import example_session_path

    session = mv.load_session(example_session_path())
    res = mv.localize(session)
    ran = set(res.timing_s) - {"total"}
    assert ran <= {p.name for p in pipeline.PASSES} and {"search", "extract", "shapes", "isolated"} <= ran
    off = mv.localize(session, swap=False, steal=False)
    assert not {"swap", "steal"} & set(off.timing_s)
    assert np.allclose(off.positions, res.positions, atol=1e-6)  # one fruit: nothing to swap or steal


def test_a_pass_returns_a_new_state() -> None:
    state = State()
    found = Found(np.zeros(3), 1.0, 0.02)
    new = state.with_objects([found])
    assert state.objects == () and new.objects == (found,)
