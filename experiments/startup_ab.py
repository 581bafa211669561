"""How much of a warm command's start does a change save, measured side by side with the code before it?

Question: ``monovisual3d localize`` on the paper scene (``monovisual3d bench startup``'s case), whole process with the
kernel cache warm, for two source trees (the commit before a change and after it, each a ``src`` folder: e.g. a
``git worktree`` of the old commit), run alternately so that both see the same load, median of ``--runs``. Beside
them, the floor every command that calls a compiled kernel stands on: ``python -c pass``, ``import numba``, and a
process that imports numba and calls one trivial cached kernel, with and without
:func:`monovisual3d.kernels.jit.load_cached_lazily`.

Answer (2026-12-07 20:20 UTC, AMD EPYC, 2 cores, idle; the commit before ``load_cached_lazily`` against it): warm
``localize`` 1.40 -> 0.92 s wall, 1.65 -> 1.06 s CPU; one trivial cached kernel 0.90 s, 0.45 s loaded lazily,
``import numba`` 0.37 s (docs/speed.md, "Cached kernels without numba's compile-time registries"). 2026-12-08 00:25
UTC, the typing declarations left out of cache loads too, typer held below 0.29 and one command's module imported
(``--before-path`` with typer 0.29 for the commit before): 1.08 -> 0.78 s wall, 1.22 -> 0.93 s CPU; one trivial cached
kernel loaded lazily 0.40 s, ``import numba`` 0.34 s.
"""

from __future__ import annotations

import argparse
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
