"""One budget for a whole command: a wall-clock limit (``--time-limit``) and a memory cap (``--max-memory``).

The work limits of :mod:`monovisual3d.limits` refuse what can be estimated before
it starts. This module bounds the rest, for a whole command run:

- :func:`time_limit` arms two timers. At ``seconds`` a ``SIGALRM`` raises
  :class:`TimeLimitExceeded` in the main thread, at the next Python bytecode,
  so ``finally`` blocks run (a batch writes the rows it has). A compiled kernel
  (numba, BLAS) does not return to Python until it ends, so a watchdog thread
  also waits ``grace_s`` more and then, with ``hard_exit``, writes the same
  one-line error to stderr and ends the process with exit code 2. Without
  ``SIGALRM`` (Windows) or outside the main thread only the watchdog acts.
- :func:`memory_limit` watches the process's resident memory (every
  :data:`POLL_S` seconds) and, once it has grown by more than ``max_bytes``, writes
  a one-line error naming ``--max-memory`` and ends the process with exit code 2,
  before the machine swaps or the out-of-memory killer acts. An allocation made
  between two looks can overshoot the cap by what it allocates.

Both are context managers that restore the previous state on exit, and both do
nothing when given ``None``.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType

from .checks import is_real
from .errors import InputError
from .limits import MAX_TIME_LIMIT_S

#: Seconds the watchdog waits after the soft limit before it ends the process (a compiled kernel may be running).
GRACE_S = 5.0
#: Seconds between two looks of the memory watchdog.
POLL_S = 0.05
#: Exit code of a process ended by the watchdog (a usage error: the limit the user set was too small).
EXIT_CODE = 2


class TimeLimitExceeded(BaseException):
    """Raised in the main thread when a :func:`time_limit` expires.

    A ``BaseException`` (like ``KeyboardInterrupt``), so the ``except Exception``
    of code that records per-item errors (a batch's sessions) does not swallow it.
    """


def check_seconds(seconds: float | None, name: str = "--time-limit") -> float | None:
    """``seconds`` as a float in (0, :data:`~monovisual3d.limits.MAX_TIME_LIMIT_S`], or None; else a one-line error."""
    if seconds is None:
        return None
    if not (is_real(seconds) and math.isfinite(seconds) and 0 < seconds <= MAX_TIME_LIMIT_S):
        raise InputError(f"{name}: got {seconds!r}, expected seconds in (0, {MAX_TIME_LIMIT_S:g}]")
    return float(seconds)


def expired_message(seconds: float, name: str = "--time-limit") -> str:
    """The one-line error of an expired limit."""
    return f"{name}: still running after {seconds:g} s, stopped; raise {name} or give the command less work"


@contextlib.contextmanager
def time_limit(
    seconds: float | None, *, name: str = "--time-limit", hard_exit: bool = False, grace_s: float = GRACE_S
) -> Iterator[None]:
    """Bound the wall-clock time of the ``with`` block (see the module docstring).

    Parameters
    ----------
    seconds : float or None, the limit; None: no limit
    name : str, the option named in the error
    hard_exit : bool, let the watchdog end the process ``grace_s`` seconds after the limit
        (for command-line runs; a library caller gets only :class:`TimeLimitExceeded`)
    grace_s : float, seconds between the soft and the hard limit

    Raises
    ------
    TimeLimitExceeded
        When the block runs past ``seconds`` (raised where the main thread is then).
    """
    seconds = check_seconds(seconds, name)
    if seconds is None:
        yield
        return
    message = expired_message(seconds, name)
    use_signal = hasattr(signal, "SIGALRM") and threading.current_thread() is threading.main_thread()
    previous = None
    if use_signal:

        def on_alarm(signum: int, frame: FrameType | None) -> None:
            raise TimeLimitExceeded(message)

        previous = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, seconds)
    watchdog = None
    if hard_exit:
        watchdog = threading.Timer(seconds + (grace_s if use_signal else 0.0), _hard_stop, args=(message,))
        watchdog.daemon = True
        watchdog.start()
    try:
        yield
    finally:
        if watchdog is not None:
            watchdog.cancel()
        if use_signal:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)


def _hard_stop(message: str) -> None:  # pragma: no cover - ends the process
    try:
        sys.stderr.write(f"error: {message}\n")
        sys.stderr.flush()
    finally:
        os._exit(EXIT_CODE)


@contextlib.contextmanager
def memory_limit(max_bytes: int | None, *, name: str = "--max-memory", poll_s: float = POLL_S) -> Iterator[None]:
    """End the process when its resident memory grows more than ``max_bytes`` during the ``with`` block.

    A watchdog thread reads the resident set size every ``poll_s`` seconds; past the
    cap it writes a one-line error naming ``name`` and ends the process with exit
    code 2 (for command-line runs). An address-space limit was tried first: libraries
    that cannot map their buffers then spin instead of failing (OpenBLAS at import).

    Parameters
    ----------
    max_bytes : int or None, bytes the block may add to the resident memory; None: no cap.
        Where ``/proc`` is missing nothing is capped.
    """
    start = _resident_bytes()
    if max_bytes is None or start is None:
        yield
        return
    cap = start + int(max_bytes)
    stop = threading.Event()

    def watch() -> None:  # pragma: no cover - runs in a thread; ends the process
        while not stop.wait(poll_s):
            rss = _resident_bytes()
            if rss is not None and rss > cap:
                _hard_stop(f"{name}: the command grew by more than {int(max_bytes) / 1024**2:.0f} MiB, stopped; raise {name}")

    thread = threading.Thread(target=watch, name="monovisual3d-memory-limit", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()


def _resident_bytes() -> int | None:
    """Resident memory of the process, bytes (``/proc/self/statm``; None where it is missing)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


__all__ = ["EXIT_CODE", "GRACE_S", "TimeLimitExceeded", "check_seconds", "memory_limit", "time_limit"]
