"""Benchmark methodology shared by every benchmark: repeated timing, machine metadata, a busy core, JSON output.

Every timed case runs ``warmup`` times untimed, then ``repeats`` times; :class:`Timing` keeps the wall
and the CPU time of each run (the CPU time is less sensitive to other jobs on a shared machine).
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import __version__


@dataclass
class Timing:
    """Wall and CPU times of repeated runs, seconds."""

    wall: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)

    def summary(self, scale: float = 1.0) -> dict[str, float]:
        """Median, min, max, IQR of the wall time and median CPU time, times ``scale`` (e.g. 1e3 for ms)."""
        w = sorted(self.wall)
        q = np.percentile(w, [25, 75]) if len(w) > 1 else [w[0], w[0]]
        return {
            "median": statistics.median(w) * scale,
            "min": w[0] * scale,
            "max": w[-1] * scale,
            "iqr": float(q[1] - q[0]) * scale,
            "cpu_median": statistics.median(self.cpu) * scale,
            "n": len(w),
        }


def time_call(fn: Callable[[], Any], repeats: int, warmup: int = 1) -> Timing:
    """Run ``fn`` ``warmup`` times untimed, then ``repeats`` times timed."""
    for _ in range(warmup):
        fn()
    t = Timing()
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        t.wall.append(time.perf_counter() - w0)
        t.cpu.append(time.process_time() - c0)
    return t


def machine_metadata() -> dict[str, Any]:
    """CPU model, cores, memory, library versions, load average."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:  # pragma: no cover - not Linux
        pass
    meta: dict[str, Any] = {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "monovisual3d": __version__,
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    try:
        with open("/proc/meminfo") as fh:
            meta["memory_gib"] = round(int(fh.readline().split()[1]) / 1024**2, 1)
    except OSError:  # pragma: no cover
        pass
    try:
        meta["load_average_1m"] = os.getloadavg()[0]
    except OSError:  # pragma: no cover
        pass
    try:
        import numba

        meta["numba"] = numba.__version__
        meta["numba_threads"] = numba.get_num_threads()
    except ImportError:  # pragma: no cover
        meta["numba"] = None
    try:
        import torch

        meta["torch"] = torch.__version__
        meta["cuda"] = torch.cuda.get_device_name(0) if torch.cuda.is_available() else None
    except ImportError:
        meta["torch"] = None
    return meta


@contextmanager
def busy_core(active: bool = True) -> Iterator[None]:
    """Run the block with a busy-loop Python process holding one core (nothing when ``active`` is False)."""
    if not active:
        yield
        return
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.2)  # let it start spinning
        yield
    finally:
        proc.kill()
        proc.wait()


def write_json(result: dict[str, Any], path: str) -> None:
    """Write a benchmark result as indented JSON (numpy numbers as floats)."""
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2, default=float)
        fh.write("\n")
