"""How the compiled kernels are built and how their first compilation shows itself.

- :func:`kernel`: ``numba.njit`` with the on-disk cache (``cache=True``) for an entry point, registered in
  :data:`KERNELS` under its group (the method whose kernels it is), so that the compile-time table
  (``docs/speed.md``) names every one. numba compiles a kernel on its first call, or loads it from the cache, one
  kernel at a time: importing a kernel module compiles nothing.
- :func:`compile_notices`: while it is active, the first compilation in the process says so once on a stream
  (``compiling kernels, first run only, about N s``), with a status line that counts the kernels on a terminal.
  The command line turns it on; the library itself prints nothing.
- :func:`record_compiles`: every compilation in a block, with its time (the compile-time table, ``bench startup``).
- :func:`load_cached_lazily`: numba loads this package's cached kernels without first importing and registering
  every implementation its compiler knows (numpy's functions, typed containers, random generators); they are
  registered when something is compiled.

numba announces a compilation (``numba:compile``) only when it compiles: a kernel loaded from the cache is silent.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, TextIO

#: The registered entry points: group -> {name: dispatcher}.
KERNELS: dict[str, dict[str, Any]] = {}
#: About how long a group's kernels take to compile from an empty cache, seconds, on the 2-core development machine
#: (``monovisual3d bench startup --compile``; the table in docs/speed.md): what the first-run notice says.
COMPILE_SECONDS: dict[str, float] = {"bayes": 10.0, "paper": 20.0, "other": 10.0}

_NOTICE: contextvars.ContextVar[TextIO | bool] = contextvars.ContextVar("monovisual3d_compile_notice", default=False)
_RECORDS: contextvars.ContextVar[list[CompileRecord] | None] = contextvars.ContextVar("monovisual3d_compiles", default=None)


@dataclass
class CompileRecord:
    """One compilation: the kernel (``module.function``), its group, wall and process CPU seconds, whether numba
    compiled it for a caller (a device function) rather than for a call from Python."""

    name: str
    group: str
    wall_s: float = 0.0
    cpu_s: float = 0.0
    nested: bool = False


def group_of(module: str) -> str:
    """The group of the kernels of ``module``: ``bayes``, ``paper`` (its engine and the shared projections), or
    ``other``."""
    if ".methods.bayes" in module:
        return "bayes"
    if ".methods.paper" in module or module.endswith(".kernels.project"):
        return "paper"
    return "other"


def kernel(group: str, **options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(cache=True, **options)`` of an entry point, registered in :data:`KERNELS` under ``group``.

    Examples
    --------
    >>> def twice(x):  # doctest: +SKIP
    ...     return 2 * x
    >>> twice = kernel("toy")(twice)  # doctest: +SKIP
    """
    import numba

    listen()
    load_cached_lazily()

    def wrap(py_func: Callable[..., Any]) -> Any:
        dispatcher = numba.njit(cache=True, **options)(py_func)
        KERNELS.setdefault(group, {})[f"{py_func.__module__.rsplit('.', 1)[-1]}.{py_func.__name__}"] = dispatcher
        return dispatcher

    return wrap


@contextlib.contextmanager
def compile_notices(stream: TextIO | None = None) -> Iterator[None]:
    """Within the block, the first kernel compilation says so on ``stream`` once (default: ``sys.stderr`` as it is
    then, so that a progress display that captures it prints the line above itself); on a terminal a status line
    counts the kernels compiled. Nothing is printed when every kernel loads from the cache."""
    token = _NOTICE.set(True if stream is None else stream)
    try:
        yield
    finally:
        _NOTICE.reset(token)
        _STATE.finish()


@contextlib.contextmanager
def record_compiles() -> Iterator[list[CompileRecord]]:
    """The compilations in the block (those of device functions inside their caller's too), in order of their end."""
    records: list[CompileRecord] = []
    token = _RECORDS.set(records)
    try:
        listen()
        yield records
    finally:
        _RECORDS.reset(token)


@dataclass
class _NoticeState:
    """What the notice has said in this process."""

    announced: bool = False
    done: int = 0
    start: float = 0.0
    stream: TextIO | None = None
    status_line: bool = False
    depth: int = 0
    open: list[tuple[float, float]] = field(default_factory=list)

    def begin(self, group: str) -> None:
        chosen = _NOTICE.get()
        if chosen is False or self.announced:
            return
        stream = sys.stderr if chosen is True else chosen
        self.announced, self.stream, self.start = True, stream, time.perf_counter()
        self.status_line = bool(getattr(stream, "isatty", lambda: False)())
        seconds = COMPILE_SECONDS.get(group, COMPILE_SECONDS["other"])
        stream.write(
            f"compiling kernels, first run only, about {seconds:.0f} s (cached afterwards; `monovisual3d warmup` "
            "compiles them ahead)\n"
        )
        stream.flush()

    def progress(self) -> None:
        self.done += 1
        if self.stream is not None and self.status_line:
            self.stream.write(f"\r  {self.done} compiled, {time.perf_counter() - self.start:.0f} s ")
            self.stream.flush()

    def finish(self) -> None:
        if self.stream is not None and self.status_line and self.done:
            self.stream.write("\n")
            self.stream.flush()
        self.stream, self.done, self.status_line, self.announced = None, 0, False, False


_STATE = _NoticeState()
_LISTENING = False


def listen() -> None:
    """Register the one listener to numba's compile events (once per process)."""
    global _LISTENING
    if _LISTENING:
        return
    from numba.core import event

    class _Listener(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            py_func = ev.data["dispatcher"].py_func
            if _STATE.depth == 0:
                _STATE.begin(group_of(py_func.__module__))
            _STATE.depth += 1
            _STATE.open.append((time.perf_counter(), time.process_time()))

        def on_end(self, ev: Any) -> None:
            py_func = ev.data["dispatcher"].py_func
            _STATE.depth -= 1
            wall0, cpu0 = _STATE.open.pop()
            records = _RECORDS.get()
            if records is not None:
                name = f"{py_func.__module__.rsplit('.', 1)[-1]}.{py_func.__name__}"
                nested = _STATE.depth > 0
                wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
                records.append(CompileRecord(name, group_of(py_func.__module__), wall, cpu, nested))
            if _STATE.depth == 0:
                _STATE.progress()

    event.register("numba:compile", _Listener())
    _LISTENING = True


_LAZY = threading.local()
_LOADING_LAZILY = False
#: Modules (prefixes of ``__module__``) whose cached kernels :func:`load_cached_lazily` loads lazily.
_LAZY_MODULES: set[str] = set()
#: numba versions whose cache loading :func:`load_cached_lazily` was written for (from, up to but not including):
#: ``Cache.load_overload`` a refresh of the target followed by ``_load_overload``, and the CPU target's
#: ``load_additional_registries`` starting with the runtime's initialisation, the target's refresh refreshing the typing
#: context's (its ``load_additional_registries``, then its builtin templates; tested with 0.68.1; 0.59.1 reads the same).
LAZY_NUMBA_VERSIONS = ((0, 59), (0, 69))


def load_cached_lazily(modules: tuple[str, ...] = ("monovisual3d",)) -> bool:
    """Let numba load the cached kernels of ``modules`` without registering its compile-time implementations first.

    Before it loads a kernel from the on-disk cache, numba refreshes its CPU target, which imports and registers
    every implementation its compiler knows (``numba.np.arraymath``, ``numba.np.linalg`` with ``scipy.linalg``, typed
    containers, random generators, ...): about 0.4 s of a command's start on the 2-core development machine, the
    largest part of a warm ``localize`` that is not the estimate (docs/speed.md). A cached ``njit`` kernel is machine
    code that runs with numba's runtime (NRT) alone, and it is typed already. For the kernels of ``modules`` (this
    package's, by default), every refresh of a cache load initialises that runtime and leaves the rest out, the typing
    context's refresh too (its declarations import ``cffi`` with its C parser and build every overload template, a
    further 0.03 s here; its builtin templates 0.016 s); a later compilation refreshes the target again and registers everything then (numba
    registers implementations incrementally), so a kernel compiled after a cached one compiles, though not always with
    numba's usual order of typing templates: where two match the same expression (a record field named like an array
    method, ``a.max``), the one installed first wins. Kernels of other modules (a user's own ``@vectorize``, whose
    ufunc wrapper numba generates after the cache load without a compilation's refresh) load as numba always loads
    them: the
    change to numba's ``Cache.load_overload`` is process-wide, its effect is not.

    Parameters
    ----------
    modules : tuple of str, module names (or their packages) whose cached kernels load lazily; calls add to the set

    Returns
    -------
    bool : True when on; False outside :data:`LAZY_NUMBA_VERSIONS` or where numba's cache has not the internals this
    relies on (``Cache._load_overload``, ``Cache._guard_against_spurious_io_errors``): numba then loads as always.
    """
    global _LOADING_LAZILY
    if not _LOADING_LAZILY:
        if not _numba_fits():
            return False
        _install_lazy_loads()
        _LOADING_LAZILY = True
    _LAZY_MODULES.update(modules)
    return True


def _numba_fits() -> bool:
    """Whether the installed numba is one whose cache loading :func:`load_cached_lazily` was written for."""
    try:
        import numba
        from numba.core import caching, cpu
    except ImportError:  # pragma: no cover - another numba layout
        return False
    version = tuple(int(p) for p in numba.__version__.split(".")[:2] if p.isdigit())
    from numba.core.typing import context as typing_context

    needed = ("load_overload", "_load_overload", "_guard_against_spurious_io_errors")
    return (
        LAZY_NUMBA_VERSIONS[0] <= version < LAZY_NUMBA_VERSIONS[1]
        and all(hasattr(caching.Cache, name) for name in needed)
        and hasattr(cpu.CPUContext, "load_additional_registries")
        and hasattr(typing_context.BaseContext, "refresh")
    )


def _install_lazy_loads() -> None:
    """Wrap numba's ``Cache.load_overload``, the ``load_additional_registries`` of its CPU target and the typing
    context's ``refresh`` (see :func:`load_cached_lazily`)."""
    from numba.core import caching, cpu
    from numba.core.runtime import rtsys
    from numba.core.typing import context as typing_context

    register_all, load = cpu.CPUContext.load_additional_registries, caching.Cache.load_overload
    refresh_typing = typing_context.BaseContext.refresh

    def load_additional_registries(self: Any) -> None:
        if getattr(_LAZY, "loading", False):
            rtsys.initialize(self)  # what a cached kernel needs: numba's runtime
            return
        register_all(self)

    def refresh_typing_unless_loading(self: Any) -> None:
        if not getattr(_LAZY, "loading", False):  # a cached kernel is typed already: the typing context's refresh
            refresh_typing(self)  # (its declarations and its builtin templates) waits for a compilation

    def load_overload(self: Any, sig: Any, target_context: Any) -> Any:
        module = str(getattr(getattr(self, "_py_func", None), "__module__", ""))
        if not any(module == m or module.startswith(m + ".") for m in _LAZY_MODULES):
            return load(self, sig, target_context)
        _LAZY.loading = True
        try:
            target_context.refresh()
        finally:
            _LAZY.loading = False
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)
        return None  # the guard swallowed an I/O error: numba compiles instead

    cpu.CPUContext.load_additional_registries = load_additional_registries
    typing_context.BaseContext.refresh = refresh_typing_unless_loading
    caching.Cache.load_overload = load_overload
