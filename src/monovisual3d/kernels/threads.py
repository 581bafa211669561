"""How many threads a parallel numba kernel gets: by the amount of work, at most what was allowed.

numba's parallel loops split the work among its threads and wait for the
slowest; its OpenMP pool spins while it waits. A call with little work per
thread (the ``bayes`` search scores a few thousand hypotheses per call) then
loses to a single thread as soon as another process holds a core, which on a
robot's computer is always. So every ``parallel=True`` entry point of the
package runs inside :func:`kernel_threads`, which sets numba's thread count
for that call from the amount of work:

- below :data:`MIN_WORK_PER_THREAD` work items per thread, fewer threads
  (one for small calls);
- never more than the limit: :func:`thread_limit` (the ``threads`` option of
  the methods, ``--threads N`` on the command line) or, without one,
  ``numba.config.NUMBA_NUM_THREADS`` (the ``NUMBA_NUM_THREADS`` environment
  variable, else the number of cores).

Work is counted in *work items* of about one nanosecond of single-thread
time: each call site multiplies its loop count (cells times views, hypotheses
times boxes) by a measured cost per iteration (``NS_PER_*`` constants next to
the calls in :mod:`monovisual3d.methods.paper.engine.dense`,
:mod:`monovisual3d.methods.paper.engine.sparse` and the ``bayes`` kernels). A
second thread starts paying off at about 20 ms of work: below that, waking
the pool and waiting for a thread that shares its core with another process
costs more than the split saves (why: docs/decisions/threads.md#min_work_per_thread).

Examples
--------
>>> threads_for(10)
1
>>> with thread_limit(1):
...     threads_for(10**9)
1
"""

from __future__ import annotations

import contextvars
import os
from collections.abc import Iterator
from contextlib import contextmanager

from ..checks import is_real
from ..errors import InputError

#: Work items (about nanoseconds of single-thread time) each thread must get: a call uses
#: ``work_items // MIN_WORK_PER_THREAD`` threads, at least one (why: docs/decisions/threads.md#min_work_per_thread).
MIN_WORK_PER_THREAD = 10_000_000

#: Environment set (unless already set) before numba starts its OpenMP pool: threads that wait
#: sleep instead of spinning on a core another process needs (why: docs/decisions/threads.md#pool_environment).
POOL_ENVIRONMENT = {"OMP_WAIT_POLICY": "PASSIVE"}

_LIMIT: contextvars.ContextVar[int | None] = contextvars.ContextVar("monovisual3d_thread_limit", default=None)


def max_threads() -> int:
    """The most threads a kernel may use: numba's pool size (``NUMBA_NUM_THREADS``, else the cores)."""
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


def check_threads(threads: object) -> int | None:
    """Validate a ``threads`` option: None (automatic) or a whole number >= 1 (numpy integers and 2.0 accepted).

    Examples
    --------
    >>> check_threads(0)
    Traceback (most recent call last):
    ...
    monovisual3d.errors.InputError: threads: got 0, expected a positive integer or None (automatic)
    """

    if threads is None:
        return None
    if not is_real(threads) or not float(threads).is_integer() or threads < 1:
        raise InputError(f"threads: got {threads!r}, expected a positive integer or None (automatic)")
    return int(threads)


def threads_for(work_items: int, requested: int | None = None) -> int:
    """Threads for a kernel call with ``work_items`` elementary evaluations.

    Parameters
    ----------
    work_items : int, the call's work (see the module docstring)
    requested : int or None, the most threads to use; None: the current :func:`thread_limit`,
        else :func:`max_threads`. Capped at :func:`max_threads` (numba cannot start more).

    Returns
    -------
    n : int, ``1 <= n <= min(requested, max_threads())``; one thread per
        :data:`MIN_WORK_PER_THREAD` work items.
    """
    requested = check_threads(requested)
    if requested is None:
        requested = _LIMIT.get()
    cap = max_threads() if requested is None else min(requested, max_threads())
    return max(1, min(cap, int(work_items) // MIN_WORK_PER_THREAD))


@contextmanager
def thread_limit(threads: int | None) -> Iterator[None]:
    """Cap the threads of every kernel called inside the block (None: no cap beyond numba's).

    The methods wrap their run in it with their ``threads`` option; nested blocks
    take the inner value. Context-local (threads and asyncio tasks each have their own).
    """
    token = _LIMIT.set(check_threads(threads))
    try:
        yield
    finally:
        _LIMIT.reset(token)


_pool_configured = False


def _configure_pool() -> None:
    """Set :data:`POOL_ENVIRONMENT` (where the user has not) once, before the first parallel call."""
    global _pool_configured
    if not _pool_configured:
        for key, value in POOL_ENVIRONMENT.items():
            os.environ.setdefault(key, value)
        _pool_configured = True


@contextmanager
def kernel_threads(work_items: int, requested: int | None = None) -> Iterator[int]:
    """Run the block with numba's thread count set to :func:`threads_for` ``(work_items, requested)``.

    Yields the count; restores the previous count afterwards (numba's count is per calling thread).
    """
    _configure_pool()
    import numba

    n = threads_for(work_items, requested)
    previous = numba.get_num_threads()
    if n == previous:
        yield n
        return
    numba.set_num_threads(n)
    try:
        yield n
    finally:
        numba.set_num_threads(previous)
