"""Spread independent work items (benchmark seeds, reproduction runs) over a Dask cluster.

``bench accuracy``, ``bench active`` and ``reproduce`` take ``--workers N`` (a local cluster
of N single-threaded processes) or ``--scheduler tcp://host:8786`` (a running cluster) and
hand their seeds out with :func:`spread_map`. Without either, the items run here, in order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from .._extras import require
from ..checks import is_int
from ..errors import InputError
from ..limits import MAX_LOCAL_WORKERS


def check_spread(workers: int | None, scheduler: str | None) -> None:
    """Raise :class:`InputError` unless at most one of ``workers`` (>= 0) and ``scheduler`` is given."""
    if workers is not None and (not is_int(workers) or workers < 0):
        raise InputError(f"workers: got {workers!r}, expected 0 (in this process) or a positive number of processes")
    if workers is not None and workers > MAX_LOCAL_WORKERS:
        raise InputError(f"workers: got {workers}, more than the {MAX_LOCAL_WORKERS} local processes accepted")
    if workers is not None and scheduler is not None:
        raise InputError("workers, scheduler: give at most one of them")


def spread_map(
    fn: Callable[..., Any],
    items: Sequence[tuple[Any, ...]],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, Any], None] | None = None,
) -> list[Any]:
    """``[fn(*item) for item in items]``, on Dask when ``workers`` (> 0) or ``scheduler`` is given.

    Parameters
    ----------
    fn : callable, importable by the workers (a module-level function of this package)
    items : sequence of argument tuples
    workers : int, local worker processes of one thread each (None or 0: run here, in order)
    scheduler : str, address of a running Dask scheduler
    progress : callable(index, result), called as each item finishes (in finishing order on Dask)

    Returns
    -------
    list, the results in the order of ``items``

    Examples
    --------
    >>> spread_map(pow, [(2, 3), (3, 2)])
    [8, 9]
    """
    check_spread(workers, scheduler)
    if not workers and scheduler is None:
        out = []
        for i, item in enumerate(items):
            out.append(fn(*item))
            if progress is not None:
                progress(i, out[-1])
        return out
    require("distributed", "dask")
    from distributed import as_completed

    from .run import dask_client

    results: list[Any] = [None] * len(items)
    with dask_client(workers or None, scheduler, dashboard_address=None) as client:
        futures = {client.submit(fn, *item, pure=False): i for i, item in enumerate(items)}
        for fut in as_completed(list(futures)):
            i = futures[fut]
            results[i] = fut.result()  # an error in an item is a bug of the benchmark: raised as is
            fut.release()
            if progress is not None:
                progress(i, results[i])
    return results
