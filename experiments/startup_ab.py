"""How much of a warm command's start does a change save, measured side by side with the code before it?

Question: ``monovisual3d localize`` on the paper scene (``monovisual3d bench startup``'s case), whole process with the
kernel cache warm, for two source trees (the commit before a change and after it, each a ``src`` folder: e.g. a
``git worktree`` of the old commit), run alternately so that both see the same load, median of ``--runs``. Beside
them, the floor every command that calls a compiled kernel stands on: ``python -c pass``, ``import numba``, and a
process that imports numba and calls one trivial cached kernel, with and without
:func:`monovisual3d.kernels.jit.load_cached_lazily`.

Answer (2026-12-08 00:45 UTC, AMD EPYC, 2 cores, idle; the commit before the typing declarations were left out of
cache loads, typer held below 0.29 and one command's module imported, with typer 0.29 through ``--before-path``):
warm ``localize`` 0.85 -> 0.67 s wall, 0.99 -> 0.81 s CPU; ``import numba`` 0.30 s, one trivial cached kernel 0.74 s,
0.34 s loaded lazily (docs/speed.md). Both trees are byte-compiled first: before that, a fresh worktree under
``PYTHONDONTWRITEBYTECODE`` recompiled every module on each run, which inflated the earlier "before" figures.
"""

from __future__ import annotations

import argparse
import compileall
import os
import statistics
import sys
import tempfile

from monovisual3d.bench.startup import busy_core, paper_scene_session, time_process

_KERNEL = """
import numba


@numba.njit(cache=True)
def add_one(x):
    return x + 1
"""


def _floor_cases(folder: str) -> dict[str, tuple[list[str], dict[str, str]]]:
    """The floor's processes: argv and extra environment."""
    with open(os.path.join(folder, "trivial_kernel.py"), "w") as f:
        f.write(_KERNEL)
    call = "import trivial_kernel; trivial_kernel.add_one(1.0)"  # found through PYTHONPATH
    lazy = "from monovisual3d.kernels.jit import load_cached_lazily; load_cached_lazily(('trivial_kernel',)); " + call
    return {
        "python -c pass": ([sys.executable, "-c", "pass"], {}),
        "import numba": ([sys.executable, "-c", "import numba"], {}),
        "numba + one cached kernel": ([sys.executable, "-c", call], {}),
        "numba + one cached kernel, loaded lazily": ([sys.executable, "-c", lazy], {}),
    }


def _folders(paths: str) -> list[str]:
    return [os.path.abspath(p) for p in paths.split(os.pathsep) if p]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before", help="the src folder of the code before the change")
    parser.add_argument("after", help="the src folder of the code after it")
    parser.add_argument("--runs", type=int, default=9)
    parser.add_argument("--busy", action="store_true", help="with another process busy on one core")
    parser.add_argument(
        "--before-path",
        default="",
        help="folders put first on the PYTHONPATH of the code before (os.pathsep-separated), e.g. the libraries it ran "
        "with, installed by `pip install --target DIR` (typer 0.29 for the commit before typer was held below it)",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder, busy_core(args.busy):
        session = paper_scene_session(folder)
        localize = [sys.executable, "-c", "from monovisual3d.cli import main; main()", "localize", session, "-q"]
        localize += ["-o", os.path.join(folder, "out.json")]
        cases = {
            "localize, before": (
                localize,
                {"PYTHONPATH": os.pathsep.join([*_folders(args.before_path), os.path.abspath(args.before)])},
            ),
            "localize, after": (localize, {"PYTHONPATH": os.path.abspath(args.after)}),
            **{
                k: (a, {"PYTHONPATH": os.pathsep.join([os.path.abspath(args.after), folder])})
                for k, (a, _) in _floor_cases(folder).items()
            },
        }
        for tree in (args.before, args.after):  # bytecode for both: where Python writes none (PYTHONDONTWRITEBYTECODE,
            compileall.compile_dir(tree, quiet=2)  # a fresh worktree), a tree without it recompiles every module
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
        for argv, env in cases.values():  # warm every kernel cache and the page cache
            time_process(argv, {**os.environ, **env})
        for _ in range(args.runs):
            for name, (argv, env) in cases.items():
                times[name].append(time_process(argv, {**os.environ, **env}))
    load = "another process busy on one core" if args.busy else "nothing else started"
    print(f"fresh processes, alternating, median of {args.runs} (wall [min-max], CPU), seconds; {load}:")
    for name, values in times.items():
        wall = sorted(w for w, _ in values)
        cpu = statistics.median(c for _, c in values)
        print(f"  {name:42s} {statistics.median(wall):.3f} [{wall[0]:.3f}-{wall[-1]:.3f}]  {cpu:.3f}")


if __name__ == "__main__":
    main()
