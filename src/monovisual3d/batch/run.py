"""Running a batch: sessions out to Dask workers, rows back into parts, parts into two tables."""

from __future__ import annotations

import asyncio
import collections
import contextlib
import itertools
import logging
import os
import sys
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from .._extras import require
from .._structured import read_capped_bytes
from ..errors import InputError
from ..errors import one_line as text_line
from ..limits import MAX_LOCAL_WORKERS
from ..result import Result
from . import tables
from .inputs import SessionInput, find_sessions
from .work import Job, config_hash, input_hash, make_job, one_line, run_job, run_jobs, session_row

#: Worker deaths a task (a chunk of sessions) may cause before it fails (Dask's ``allowed-failures``); a failed
#: chunk is split and each session retried alone, with the same allowance.
DEFAULT_MAX_WORKER_DEATHS = 3

#: Most sessions per Dask task when ``chunk_size`` is not given.
MAX_CHUNK = 16

#: What a script that starts local workers must do: each worker process is spawned and imports the main module,
#: so a call at the script's top level would run again in every worker.
MAIN_GUARD_HINT = 'a script that starts local workers must do so under `if __name__ == "__main__":` (each worker imports it)'


class BatchTables(NamedTuple):
    """The two tables of a batch: pandas DataFrames with the dtypes of
    :data:`~.tables.FRUIT_COLUMNS` and :data:`~.tables.SESSION_COLUMNS`."""

    fruit: Any
    sessions: Any

    @property
    def summary(self) -> dict[str, Any]:
        """Counts and pooled evaluation, as written to ``summary.json`` (see :func:`~.tables.summarize`)."""
        return tables.summarize(self.fruit, self.sessions)


@dataclass(frozen=True)
class BatchProgress:
    """Where a batch stands, passed to the ``progress`` callback after each session.

    Attributes
    ----------
    done : int, sessions finished in this run (ok or error)
    total : int, sessions to run in this run (skipped ones excluded)
    failed : int, sessions of this run that ended with an error
    skipped : int, sessions skipped because ``resume`` found them in the output
    elapsed_s : float, seconds since the first session was sent
    workers : int, worker threads of the cluster (0: in-process)
    dashboard : str or None, the Dask dashboard address when there is one
    last : dict or None, the ``sessions`` row that just arrived (None in the first call, before any session)
    """

    done: int
    total: int
    failed: int
    skipped: int
    elapsed_s: float
    workers: int
    dashboard: str | None = None
    last: dict[str, Any] | None = None


def _sha256(path: Path) -> str:
    try:
        return input_hash(read_capped_bytes(path))
    except InputError:
        return ""  # unreadable: never done, reported when it is read for the run


def _killed_row(job: Job, exc: BaseException, max_deaths: int | None) -> dict[str, Any]:
    limit = f" (allowed-failures {max_deaths})" if max_deaths is not None else ""
    if type(exc).__name__ == "KilledWorker":
        message = f"{job.path}: the workers running this session died too often{limit}: killed or out of memory"
    else:
        message = f"{job.path}: {one_line(exc)}"
    return session_row(job, status="error", error=message, error_type=type(exc).__name__)


def check_not_spawned_import() -> None:
    """Raise :class:`InputError` when called while a spawned worker process imports the main script (a script that
    starts local workers at its top level, without the ``__main__`` guard): the call would start workers again there."""
    # multiprocessing's spawn runs the script as ``__mp_main__`` beside the child's own ``__main__``, then makes them one;
    # only in a child process (a notebook replaces ``__main__`` in the main process, leaving the two apart for good)
    mp_main = sys.modules.get("__mp_main__")
    if mp_main is not None and mp_main is not sys.modules.get("__main__") and not _in_main_process():
        raise InputError(
            f"workers: local Dask workers asked for while a worker process imports the main script; {MAIN_GUARD_HINT}"
        )


def _in_main_process() -> bool:
    """Whether this is the process Python was started as (not one that multiprocessing started)."""
    import multiprocessing

    return multiprocessing.current_process().name == "MainProcess"


@contextlib.contextmanager
def dask_client(
    workers: int | None = None,
    scheduler: str | None = None,
    max_worker_deaths: int = DEFAULT_MAX_WORKER_DEATHS,
    dashboard_address: str | None = None,
) -> Iterator[Any]:
    """A ``distributed.Client`` on ``scheduler``, or on the local cluster :func:`run` starts (closed on exit).

    The local cluster has ``workers`` processes (default one per core) of one
    thread each, numba limited to one thread, ``allowed-failures`` set to
    ``max_worker_deaths`` and one task (a chunk of sessions) at a time per worker.
    Raises :class:`InputError` when ``scheduler`` cannot be reached, when the local workers do not start, and when
    called while a spawned worker imports the main script (a script's top level without the ``__main__`` guard).
    """
    require("distributed", "dask")
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler)
        except (OSError, TimeoutError, ValueError) as exc:  # refused, timed out, or not an address
            reason = " ".join(str(exc).split()) or type(exc).__name__
            raise InputError(f"scheduler: cannot connect to {scheduler!r}: {reason}") from None
        with client:
            yield client
        return
    check_not_spawned_import()
    n = workers if workers is not None else (os.cpu_count() or 1)
    # One single-threaded process per core; numba's thread pool is sized to match so processes don't compete.
    # A worker holds one task at a time (saturation 1.0): when it dies, only the chunk it was running counts a
    # failure (Dask counts one for every task a dead worker held).
    # Dask sets MALLOC_TRIM_THRESHOLD_ in its workers, which turns off glibc's adaptive mmap threshold: every
    # large grid is then a fresh mmap + page faults (measured 1.6 s vs 1.0 s per paper session); unset it.
    # The worker profiler is off (a dashboard's profile page is then empty).
    config = {
        "distributed.scheduler.allowed-failures": max_worker_deaths,
        "distributed.scheduler.worker-saturation": 1.0,
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        # the statistical profiler samples every worker thread every 10 ms: CPU a short session pays for
        "distributed.worker.profile.enabled": False,
    }
    with dask.config.set(config):
        try:
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=dashboard_address,
                silence_logs=logging.ERROR,
                env={"NUMBA_NUM_THREADS": "1"},
            )
        except RuntimeError as exc:  # a worker process failed to start (distributed: "Nanny failed to start.")
            raise InputError(
                f"workers: could not start {n} local Dask workers ({text_line(str(exc))}); {MAIN_GUARD_HINT}"
            ) from None
        with cluster, Client(cluster) as client:
            yield client


def _dashboard(client: Any) -> str | None:
    try:
        services = client.scheduler_info().get("services", {})
    except Exception:  # pragma: no cover - information only
        return None
    return client.dashboard_link if "dashboard" in services else None


def run(
    inputs: Sequence[str | Path] | str | Path,
    output: str | Path,
    *,
    method: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    resume: bool = False,
    part_size: int = 100,
    part_seconds: float = 5.0,
    max_worker_deaths: int = DEFAULT_MAX_WORKER_DEATHS,
    chunk_size: int | None = None,
    localizer: Callable[..., Result] | None = None,
    progress: Callable[[BatchProgress], None] | None = None,
    dashboard_address: str | None = ":8787",
    **options: Any,
) -> BatchTables:
    """Localise many sessions on a Dask cluster and collect one table of fruit and one of sessions.

    One unit of thought: the public batch entry point; its documented options make most of its length, the body checks them and hands the work to the runner.

    A bad session is recorded in ``sessions`` with its one-line error and the batch goes on.
    A worker that dies has its sessions retried on other workers; a session whose workers die
    ``max_worker_deaths`` times is recorded as failed (``error_type`` ``KilledWorker``). Rows are
    written to ``output/parts`` as they arrive (every ``part_size`` sessions or ``part_seconds``),
    then consolidated into ``fruit``/``sessions`` Parquet and CSV files and ``summary.json``.

    Parameters
    ----------
    inputs : session files, folders (searched recursively) or globs (see :func:`find_sessions`)
    output : folder for the tables (created); must hold no earlier batch unless ``resume``
    method : str, the localisation method (default :data:`monovisual3d.localize.DEFAULT_METHOD`)
    workers : int, local worker processes, one thread each (default one per core);
        0 runs in this process without Dask
    scheduler : str, address of a running Dask scheduler (``tcp://host:8786``) to use instead
    client : distributed.Client, an existing client to use instead
    resume : bool, skip the sessions whose id, input hash and options hash are already in ``output``
    part_size : int, sessions per written part
    part_seconds : float, longest time a finished session waits before it is written, seconds
    max_worker_deaths : int, worker deaths a task (chunk) may cause before it fails
        (local cluster only; a running scheduler keeps its own ``distributed.scheduler.allowed-failures``).
        A chunk whose workers die that often is split and its sessions retried one by one
        (a session that kills every worker is recorded after up to twice this many deaths).
    chunk_size : int, sessions per Dask task (default: up to :data:`MAX_CHUNK`, at least
        four chunks per worker thread); fewer tasks, less overhead per session
    localizer : callable(session, method=..., **options) -> Result, default :func:`monovisual3d.localize`
    progress : callable(BatchProgress), called after each session
    dashboard_address : str or None, where the local cluster serves its dashboard (needs bokeh); None for none
    **options
        Method options, passed to ``localize(session, method=method, **options)``.

    Returns
    -------
    BatchTables
        ``(fruit, sessions)``: pandas DataFrames of everything in ``output``
        (earlier runs included when resuming); ``.summary`` is the dict of ``summary.json``.

    Examples
    --------
    >>> import tempfile
    >>> from monovisual3d.examples import example_session_path
    >>> fruit, sessions = run([example_session_path()], tempfile.mkdtemp(), method="paper", workers=0, resolution=0.01)
    >>> list(sessions["status"]), len(fruit)
    (['ok'], 1)
    """
    method = method or _default_method()
    _check_run_args(method, localizer, workers, scheduler, client, part_size, max_worker_deaths, chunk_size, output, resume)
    _check_options(method, localizer, options)
    if workers != 0 and scheduler is None and client is None:
        check_not_spawned_import()
    tables.require_libraries()
    found, output = find_sessions(inputs), Path(output)
    _prepare_output(found, output)
    with tables.OutputLock(output):
        done = _done_keys(output, resume)
        writer = tables.PartWriter(output, part_size=part_size, part_seconds=part_seconds)
        runner = _Runner(found, done, method, options, config_hash(method, options), writer, progress, chunk_size)
        try:
            _dispatch(runner, localizer, workers, scheduler, client, max_worker_deaths, dashboard_address)
        finally:
            writer.flush()
        fruit, sessions, _ = tables.consolidate(output)
    return BatchTables(fruit, sessions)


def _dispatch(
    runner: _Runner,
    localizer: Callable[..., Result] | None,
    workers: int | None,
    scheduler: str | None,
    client: Any,
    max_worker_deaths: int,
    dashboard_address: str | None,
) -> None:
    """Run ``runner`` in this process (``workers == 0``), on ``client``, or on a cluster of :func:`dask_client`."""
    if workers == 0:
        runner.run_in_process(localizer)
    elif client is not None:
        runner.run_dask(client, localizer, None)
    else:
        with dask_client(workers, scheduler, max_worker_deaths, dashboard_address) as c:
            runner.run_dask(c, localizer, max_worker_deaths if scheduler is None else None)


def _check_run_args(
    method: str,
    localizer: Callable[..., Result] | None,
    workers: int | None,
    scheduler: str | None,
    client: Any,
    part_size: int,
    max_worker_deaths: int,
    chunk_size: int | None,
    output: str | Path,
    resume: bool,
) -> None:
    """Raise :class:`InputError` on the first bad argument of :func:`run`, in its order."""
    from ..api import METHODS

    if method not in METHODS and localizer is None:
        raise InputError(f"method: got {method!r}, expected one of {sorted(METHODS)}")
    if workers is not None and workers < 0:
        raise InputError(f"workers: got {workers}, expected 0 (in-process) or a positive number of processes")
    if workers is not None and workers > MAX_LOCAL_WORKERS:
        raise InputError(f"workers: got {workers}, more than the {MAX_LOCAL_WORKERS} local processes accepted")
    given = [name for name, value in (("workers", workers), ("scheduler", scheduler), ("client", client)) if value is not None]
    if len(given) > 1:
        raise InputError(f"{', '.join(given)}: give at most one of them")
    if part_size < 1:
        raise InputError(f"part_size: got {part_size}, expected a positive number of sessions")
    if max_worker_deaths < 1:
        raise InputError(f"max_worker_deaths: got {max_worker_deaths}, expected a positive integer")
    if chunk_size is not None and chunk_size < 1:
        raise InputError(f"chunk_size: got {chunk_size}, expected a positive number of sessions per task")
    output = Path(output)
    if output.exists() and not output.is_dir():
        raise InputError(f"{output}: exists and is not a folder")
    if not resume and tables.has_parts(output):
        raise InputError(f"{output}: holds an earlier batch; resume it, or choose an empty folder")


def _done_keys(output: Path, resume: bool) -> set[tuple[str, str, str]]:
    """The sessions done in ``output`` when resuming; without ``resume`` a folder with parts is refused
    (checked again under the lock: a run may have started since :func:`_check_run_args` looked)."""
    if not resume and tables.has_parts(output):
        raise InputError(f"{text_line(str(output))}: holds an earlier batch; resume it, or choose an empty folder")
    return tables.done_keys(output) if resume else set()


def _prepare_output(found: list[SessionInput], output: Path) -> None:
    """Create the output folder, refusing one that cannot be created or whose tables would overwrite a session
    (``summary.json`` matched by a glob)."""
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"{text_line(str(output))}: cannot create the output folder ({exc.strerror or type(exc).__name__})"
        ) from None
    written = {(output / name).resolve() for name in tables.WRITTEN_FILES}
    for s in found:
        if s.path.resolve() in written:
            raise InputError(
                f"{text_line(str(s.path))}: is also an output of this batch; refusing to overwrite it, choose another --output"
            )


def _default_method() -> str:
    from ..api import DEFAULT_METHOD

    return DEFAULT_METHOD


def _check_options(method: str, localizer: Callable[..., Result] | None, options: dict[str, Any]) -> None:
    """Raise :class:`InputError` on a bad method option: it is the same for every session, so say it once, before any work."""
    if localizer is None:
        from ..methods import get_method

        get_method(method).make_config(**options)


class _Runner:
    """The client side of one run: reads sessions, hands them out, writes what comes back."""

    def __init__(
        self,
        found: list[SessionInput],
        done: set[tuple[str, str, str]],
        method: str,
        options: dict[str, Any],
        cfg_hash: str,
        writer: tables.PartWriter,
        progress: Callable[[BatchProgress], None] | None,
        chunk_size: int | None = None,
    ) -> None:
        self.found, self.done_keys = found, done
        self.chunk_size = chunk_size
        self.method, self.options, self.cfg_hash = method, options, cfg_hash
        self.writer, self.progress = writer, progress
        self.done = self.failed = 0
        if done:  # resuming: find what is done first, so that the total is right from the start
            self.found = [s for s in found if (s.session_id, _sha256(s.path), cfg_hash) not in done]
        self.skipped = len(found) - len(self.found)
        self.total = len(self.found)
        self.t0 = time.perf_counter()
        self.workers = 0
        self.dashboard: str | None = None

    def jobs(self) -> Iterator[Job]:
        """The jobs to run, read one at a time; unreadable files and resumed sessions are handled here."""
        for s in self.found:
            if s.error is not None:  # an unreadable folder: a failed row, never a silent skip
                job = Job(s.session_id, str(s.path), "", "", self.method, self.options, self.cfg_hash)
                self.record(session_row(job, status="error", error=s.error, error_type="OSError"), [])
                continue
            try:
                job = make_job(s.path, s.session_id, s.truth_path, self.method, self.options, self.cfg_hash)
            except (OSError, UnicodeError, InputError) as exc:
                job = Job(s.session_id, str(s.path), "", "", self.method, self.options, self.cfg_hash)
                message = f"{exc.filename or s.path}: {exc.strerror or exc}" if isinstance(exc, OSError) else str(exc)
                self.record(session_row(job, status="error", error=message, error_type=type(exc).__name__), [])
                continue
            if (job.session_id, job.input_sha256, job.config_sha256) in self.done_keys:  # changed back since the first look
                self.skipped += 1
                self.total -= 1
                continue
            yield job

    def record(self, row: dict[str, Any], fruit: list[dict[str, Any]]) -> None:
        now = time.perf_counter()
        self.writer.add(row, fruit, now)
        self.done += 1
        self.failed += row["status"] != "ok"
        self.report(now, row)

    def report(self, now: float, row: dict[str, Any] | None = None) -> None:
        if self.progress is not None:
            self.progress(
                BatchProgress(self.done, self.total, self.failed, self.skipped, now - self.t0, self.workers, self.dashboard, row)
            )

    def run_in_process(self, localizer: Callable[..., Result] | None) -> None:
        self.t0 = time.perf_counter()
        self.report(self.t0)
        for job in self.jobs():
            self.record(*run_job(job, localizer))

    def chunk(self, threads: int) -> int:
        """Sessions per task: ``chunk_size``, or up to :data:`MAX_CHUNK` with at least four chunks per thread."""
        if self.chunk_size is not None:
            return self.chunk_size
        return max(1, min(MAX_CHUNK, self.total // (4 * threads)))

    def run_dask(self, client: Any, localizer: Callable[..., Result] | None, max_deaths: int | None) -> None:
        from distributed import as_completed

        self.workers = max(1, sum(client.nthreads().values()))
        self.dashboard = _dashboard(client)
        size = self.chunk(self.workers)
        # A bounded window of chunks in flight: memory stays flat for any batch size, and a client
        # that stops loses at most these (plus the rows waiting for the next part).
        window = max(4, 2 * self.workers) if size > 1 else max(16, 4 * self.workers)
        jobs = self.jobs()
        retry: collections.deque[list[Job]] = collections.deque()  # sessions of a lost chunk, one task each
        pending: dict[Any, list[Job]] = {}
        run_token, counter = uuid.uuid4().hex[:12], itertools.count()
        self.t0 = time.perf_counter()
        self.report(self.t0)

        def submit_next() -> Any:
            chunk = retry.popleft() if retry else list(itertools.islice(jobs, size))
            if not chunk:
                return None
            key = f"monovisual3d-batch-{run_token}-{next(counter)}-{chunk[0].input_sha256[:12]}"
            fut = client.submit(run_jobs, chunk, localizer, pure=False, key=key)
            pending[fut] = chunk
            return fut

        queue = as_completed([f for f in (submit_next() for _ in range(window)) if f is not None])
        for fut in queue:
            chunk = pending.pop(fut)
            try:
                # result() waits again when a finished result was lost with its worker and is being recomputed
                results = fut.result()
            except (Exception, asyncio.CancelledError) as exc:  # KilledWorker, a cancelled task: not the session's fault
                if len(chunk) > 1:  # find the session at fault: each one again, alone
                    retry.extend([job] for job in chunk)
                    results = []
                else:
                    results = [(_killed_row(chunk[0], exc, max_deaths), [])]
            fut.release()
            for row, fruit in results:
                self.record(row, fruit)
            for _ in range(len(chunk) if not results else 1):  # one task per finished one; a split chunk adds its singles
                nxt = submit_next()
                if nxt is not None:
                    queue.add(nxt)
