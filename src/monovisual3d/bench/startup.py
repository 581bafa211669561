"""Start-up benchmark: what a command costs before and around its work, in fresh processes.

- ``import monovisual3d`` and ``monovisual3d --help``, idle and with a busy-loop process on one core (:func:`run_startup`);
- ``monovisual3d localize`` on the paper scene (6 fruit, 3 views, 3 % box noise), the whole process, with the
  compiled-kernel cache warm and empty (``NUMBA_CACHE_DIR`` a new folder each run: a fresh clone's first run)
  (:func:`run_localize`);
- the import time of each command's path: the command run once with ``python -X importtime``, its imports summed
  (:func:`run_imports`);
- the compile time of each kernel from an empty cache (:func:`run_compile_table`, the table in docs/speed.md).

Each run is a new interpreter, timed from outside with a monotonic clock after one warm-up run (which fills the OS
file cache and Python's bytecode cache), its CPU time (user + system, all threads) from the operating system. The
median and the spread over the runs are reported.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
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


#: The issue's targets (issue 56), seconds: ``localize`` on the paper scene, whole process, kernel cache warm (median
#: of 7 on the 2-core development machine, idle) and a fresh clone's first run (empty kernel cache).
TARGET_WARM_S, TARGET_COLD_S = 0.6, 15.0
#: Box noise of the benchmark's paper scene (std as a fraction of the box size).
BOX_NOISE = 0.03
#: The commands whose import path is timed, as arguments after ``monovisual3d``, in this order (``evaluate`` reads
#: what ``localize`` wrote); ``{dir}`` is the work folder with the paper scene's session.json and truth.json.
COMMANDS = {
    "localize": ["localize", "{dir}/session.json", "-q", "-o", "{dir}/result.json"],
    "evaluate": ["evaluate", "{dir}/result.json", "{dir}/truth.json"],
    "simulate": ["simulate", "-o", "{dir}/sim", "--no-images"],
    "view": ["view", "{dir}/session.json", "-o", "{dir}/view.html"],
    "warmup": ["warmup", "--methods", "bayes"],
}


#: The command line in a fresh interpreter (``python -m monovisual3d.cli``).
_CLI = [sys.executable, "-c", "from monovisual3d.cli import main; main()"]


def paper_scene_session(folder: str | os.PathLike[str]) -> str:
    """Write the benchmark's paper scene (session.json, truth.json) into ``folder``; the session's path."""
    from ..sim.noise import NoiseModel
    from ..sim.scenes import paper_scene
    from ..sim.simulate import write_simulation

    write_simulation(folder, paper_scene(), noise=NoiseModel(box_sigma=BOX_NOISE), rng=0, images=False)
    return os.path.join(folder, "session.json")


def time_process(argv: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """Wall and CPU seconds (user + system of the child and its threads) of one process; it must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def spread(values: list[float]) -> dict[str, float]:
    """Median, min and max of ``values``."""
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def run_localize(folder: str, runs: int = 7, cold_runs: int = 1) -> dict[str, Any]:
    """Whole-process ``monovisual3d localize`` on the paper scene: ``runs`` with the kernel cache warm (after one
    warm-up run that fills it), ``cold_runs`` each with a new, empty ``NUMBA_CACHE_DIR``."""
    session = paper_scene_session(folder)
    argv = [*_CLI, "localize", session, "-q", "-o", os.path.join(folder, "out.json")]
    out: dict[str, Any] = {}
    for case, n, cold in (("warm cache", runs, False), ("empty cache", cold_runs, True)):
        if not n:
            continue
        walls, cpus = [], []
        for i in range(n + (0 if cold else 1)):
            env = None
            if cold:
                env = {**os.environ, "NUMBA_CACHE_DIR": tempfile.mkdtemp(prefix="mv3d-kernels-", dir=folder)}
            wall, cpu = time_process(argv, env)
            if cold or i:
                walls.append(wall)
                cpus.append(cpu)
        target = TARGET_COLD_S if cold else TARGET_WARM_S
        out[case] = {"runs": n, "wall_s": spread(walls), "cpu_s": spread(cpus), "target_s": target}
        out[case]["met"] = out[case]["wall_s"]["median"] <= target
    return out


def import_seconds(importtime_log: str) -> float:
    """Seconds of all imports in a ``python -X importtime`` log: the sum of its top-level cumulative times."""
    total = 0
    for line in importtime_log.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and line.startswith("import time:") and parts[1].strip().isdigit():
            name = parts[2]
            if name.strip() and len(name) - len(name.lstrip()) == 1:  # top level: one space after the bar
                total += int(parts[1])
    return total / 1e6


def run_imports(folder: str, runs: int = 3) -> dict[str, dict[str, float]]:
    """Per command of :data:`COMMANDS`: the seconds its imports take, median of ``runs`` (after one untimed run)."""
    paper_scene_session(folder)
    out = {}
    for name, args in COMMANDS.items():
        argv = [sys.executable, "-X", "importtime", *_CLI[1:], *(a.format(dir=folder) for a in args)]
        seconds = []
        for i in range(runs + 1):
            proc = subprocess.run(argv, capture_output=True, text=True, check=True)
            if i:
                seconds.append(import_seconds(proc.stderr))
        out[name] = spread(seconds)
    return out


#: Run in a fresh interpreter with an empty kernel cache: every kernel of every compiled method, compiled and timed.
_COMPILE_SCRIPT = """
import json, sys, time
from monovisual3d.kernels.jit import record_compiles
from monovisual3d.api import warmup
rows = []
for method in sys.argv[1].split(","):
    c0 = time.process_time()
    with record_compiles() as records:
        warmup([method])
    rows += [dict(r.__dict__, method=method) for r in records]
    rows.append(dict(name="(all)", group=method, method=method, wall_s=0.0, cpu_s=time.process_time() - c0, nested=False))
print(json.dumps(rows))
"""


def run_compile_table(methods: tuple[str, ...] = ("bayes", "paper")) -> list[dict[str, Any]]:
    """Compile time of each kernel of ``methods`` from an empty cache, in one fresh process: one row per compiled
    function (device functions compiled for their caller marked ``nested``; a kernel's time includes theirs), and a
    row ``(all)`` per method with the CPU seconds of its whole warm-up (imports and numba's own start included)."""
    with tempfile.TemporaryDirectory(prefix="mv3d-kernels-") as cache:
        proc = subprocess.run(
            [sys.executable, "-c", _COMPILE_SCRIPT, ",".join(methods)],
            capture_output=True,
            text=True,
            check=True,
            env={**os.environ, "NUMBA_CACHE_DIR": cache},
        )
    rows = json.loads(proc.stdout.strip().splitlines()[-1])
    return [r for r in rows if r["group"] != "other"]  # numba's own helpers (array constructors), a few ms each
