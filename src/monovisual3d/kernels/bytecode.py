"""This package's Python bytecode, written where Python writes none.

Python caches a module's bytecode (``__pycache__/*.pyc``) when it first imports it, unless told not to
(``PYTHONDONTWRITEBYTECODE=1`` or ``python -B``: common in Docker images). A wheel that pip installs is byte-compiled
at install; an editable install (``pip install -e .``, as the README's quick start does) is not, and under that
setting every command then compiles again every module of this package it imports: 0.17 s of a warm ``localize``
on the 2-core development machine (0.69 -> 0.85 s, docs/speed.md). Python reads bytecode that exists whatever the
setting; it only does not write it.

- :func:`stale_sources`: the source files among given ones whose bytecode is missing or does not match them.
- :func:`compile_sources`: compile those where their ``__pycache__`` folder can be written.
- :func:`cache_imported_bytecode`: what the command line does at the end of each command: where Python writes no
  bytecode, write that of this package's modules the command imported (once: afterwards they are current, and the
  check reads a 16-byte header per module). ``monovisual3d warmup`` writes the whole package's
  (:func:`monovisual3d.api.write_bytecode`). ``MONOVISUAL3D_WRITE_BYTECODE=0`` turns the command line's off (a
  source tree mounted into a container, whose ``__pycache__`` folders must stay the host's).
"""

from __future__ import annotations

import importlib.util
import os
import py_compile
import sys
from collections.abc import Iterable
from pathlib import Path

#: The header of a bytecode file (PEP 552): magic number, flags, then the source's modification time and size
#: (flags 0) or its hash (flags 3: checked, 1: unchecked).
_HEADER_BYTES = 16
_CHECKED_HASH, _UNCHECKED_HASH = 3, 1
#: Set to ``0`` to keep the command line from writing bytecode where Python writes none (a source tree mounted into a
#: container, whose ``__pycache__`` folders must stay the host's).
WRITE_ENV = "MONOVISUAL3D_WRITE_BYTECODE"


def bytecode_is_current(source: str | os.PathLike[str]) -> bool:
    """Whether the bytecode Python would read for ``source`` exists and matches it, as the import system checks it.

    A timestamp-based file matches when its recorded modification time (whole seconds) and size are the source's; a
    checked hash-based one (``SOURCE_DATE_EPOCH`` builds) when its recorded hash is the source's; an unchecked one is
    never checked by Python, so it is current.
    """
    source = os.fspath(source)
    try:
        stat = os.stat(source)
        with open(importlib.util.cache_from_source(source), "rb") as f:
            header = f.read(_HEADER_BYTES)
        if len(header) < _HEADER_BYTES or header[:4] != importlib.util.MAGIC_NUMBER:
            return False
        flags = int.from_bytes(header[4:8], "little")
        if flags == _UNCHECKED_HASH:
            return True
        if flags == _CHECKED_HASH:
            with open(source, "rb") as f:
                return header[8:16] == importlib.util.source_hash(f.read())
    except (OSError, ValueError, NotImplementedError):
        return False
    if flags != 0:  # no flags Python knows
        return False
    mtime, size = int.from_bytes(header[8:12], "little"), int.from_bytes(header[12:16], "little")
    return mtime == (int(stat.st_mtime) & 0xFFFFFFFF) and size == (stat.st_size & 0xFFFFFFFF)


def stale_sources(sources: Iterable[str | os.PathLike[str]]) -> list[str]:
    """Those of the source files ``sources`` (``.py``) whose bytecode is missing or does not match them, in order."""
    return [s for s in map(os.fspath, sources) if s.endswith(".py") and not bytecode_is_current(s)]


def _writable(source: str) -> bool:
    """Whether the bytecode file of ``source`` can be written: its folder, or the nearest one above it that exists
    (``__pycache__`` or a ``PYTHONPYCACHEPREFIX`` tree is made on writing)."""
    try:
        folder = os.path.dirname(os.path.abspath(importlib.util.cache_from_source(source)))
    except (OSError, ValueError, NotImplementedError):
        return False
    while not os.path.isdir(folder):
        parent = os.path.dirname(folder)
        if parent == folder:
            return False
        folder = parent
    return os.access(folder, os.W_OK)


def compile_sources(sources: Iterable[str | os.PathLike[str]]) -> int:
    """Compile each of ``sources`` to its bytecode file, where its ``__pycache__`` folder can be written; the number
    written. A file that does not compile (or cannot be written) is left alone: importing it says why."""
    written = 0
    for source in map(os.fspath, sources):
        if not _writable(source):  # checked first: compiling costs more than the check
            continue
        try:
            py_compile.compile(source, doraise=True, invalidation_mode=py_compile.PycInvalidationMode.TIMESTAMP)
        except (py_compile.PyCompileError, OSError):
            continue
        written += 1
    return written


def package_sources() -> list[Path]:
    """Every source file of this package, sorted."""
    return sorted(Path(__file__).resolve().parent.parent.rglob("*.py"))


def cache_imported_bytecode() -> int:
    """Where Python writes no bytecode (``sys.dont_write_bytecode``), write that of this package's imported modules
    that have none current; the number written (0 where Python writes it itself, or where :data:`WRITE_ENV` is
    ``0``). A cache: nothing that goes wrong here stops the command that ran."""
    if not sys.dont_write_bytecode or os.environ.get(WRITE_ENV, "1").strip() == "0":
        return 0
    package = __name__.split(".")[0]
    ours = [m for name, m in list(sys.modules.items()) if name == package or name.startswith(package + ".")]
    try:
        return compile_sources(stale_sources(str(getattr(m, "__file__", None) or "") for m in ours))
    except Exception:  # noqa: BLE001 - a bytecode cache never turns a finished command into a traceback
        return 0
