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
- :func:`memory_limit` caps the process's address space (``RLIMIT_AS``) at what it
  uses now plus ``max_bytes``: an allocation beyond it raises ``MemoryError``
  instead of swapping or waking the out-of-memory killer. The CLI turns that
  into a one-line error naming ``--max-memory``. Address space counts mapped
  but unused memory too, so the cap is a ceiling, not a measure.

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

from .errors import InputError
from .limits import MAX_TIME_LIMIT_S

#: Seconds the watchdog waits after the soft limit before it ends the process (a compiled kernel may be running).
GRACE_S = 5.0
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
    if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and 0 < seconds <= MAX_TIME_LIMIT_S):
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
def memory_limit(max_bytes: int | None) -> Iterator[None]:
    """Cap the process's address space at its current size plus ``max_bytes`` for the ``with`` block.

    Parameters
    ----------
    max_bytes : int or None, bytes the block may add; None: no cap. Where ``resource``
        is missing (Windows) nothing is capped.
    """
    if max_bytes is None:
        yield
        return
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = _address_space() + int(max_bytes)
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _address_space() -> int:
    """Bytes of address space the process maps now (``VmSize``; 0 where /proc is missing)."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


__all__ = ["EXIT_CODE", "GRACE_S", "TimeLimitExceeded", "check_seconds", "memory_limit", "time_limit"]
