"""Start-up benchmark: ``import monovisual3d`` and ``monovisual3d --help`` in fresh processes.

Each run is a new interpreter (``python -c ...``), timed from outside with a
monotonic clock after one warm-up run (which fills the OS file cache and
Python's bytecode cache). The median and the spread over the runs are
reported, idle and with a busy-loop process on one core.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import Any

#: What is timed: name -> Python code run in a fresh interpreter.
CASES = {
    "import monovisual3d": "import monovisual3d",
    "monovisual3d --help": "import sys; sys.argv = ['monovisual3d', '--help']\nfrom monovisual3d.cli import main\ntry:\n    main()\nexcept SystemExit:\n    pass",
}
#: Targets, seconds: issue 21's (a newcomer's first hour), which tightened issue 10's 0.3 and 0.5 s; the README's.
TARGETS = {"import monovisual3d": 0.1, "monovisual3d --help": 0.3}


@dataclass(frozen=True)
class StartupRow:
    """One timed case: median, min and max wall seconds over ``runs`` fresh processes."""

    case: str
    load: str
    runs: int
    median_s: float
    min_s: float
    max_s: float
    target_s: float

    @property
    def met(self) -> bool:
        return self.median_s <= self.target_s


@contextmanager
def busy_core(busy: bool) -> Iterator[None]:
    """A busy-loop process on one core while the block runs (nothing when ``busy`` is False)."""
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if busy else None
    try:
        if proc is not None:
            time.sleep(0.3)
        yield
    finally:
        if proc is not None:
            proc.kill()
            proc.wait()


def time_case(code: str, runs: int) -> list[float]:
    """Wall seconds of ``runs`` fresh interpreters running ``code`` (after one warm-up)."""
    out = []
    for i in range(runs + 1):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
        if i:
            out.append(time.perf_counter() - t0)
    return out


def run_startup(runs: int = 7) -> list[StartupRow]:
    """Time every case idle and with one busy core."""
    rows = []
    for load in ("idle", "busy core"):
        with busy_core(load != "idle"):
            for case, code in CASES.items():
                t = time_case(code, runs)
                rows.append(StartupRow(case, load, runs, statistics.median(t), min(t), max(t), TARGETS[case]))
    return rows


def rows_to_dicts(rows: list[StartupRow]) -> list[dict[str, Any]]:
    return [{**asdict(r), "met": r.met} for r in rows]
