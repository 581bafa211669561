"""The package's bytecode written where Python writes none (:mod:`monovisual3d.kernels.bytecode`, issue 56)."""

from __future__ import annotations

import importlib.util
import os
import py_compile
import sys
from pathlib import Path

import pytest

from monovisual3d.kernels import bytecode


def _module(folder: Path, name: str, text: str) -> Path:
    source = folder / f"{name}.py"
    source.write_text(text)
    return source


def _import(source: Path, name: str) -> object:
    spec = importlib.util.spec_from_file_location(name, source)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_written_bytecode_is_current_and_is_what_python_reads(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    source = _module(tmp_path, "probe_read", "X = 1\n")
    assert not bytecode.bytecode_is_current(source)
    assert bytecode.stale_sources([source, tmp_path / "notes.txt"]) == [str(source)]
    assert bytecode.compile_sources([source]) == 1
    assert bytecode.bytecode_is_current(source) and bytecode.stale_sources([source]) == []
    # the same size and modification time, other text: Python takes the bytecode, so it reads X = 1
    stat = source.stat()
    source.write_text("X = 2\n")
    os.utime(source, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert _import(source, "probe_read").X == 1  # type: ignore[attr-defined]


def test_a_changed_source_makes_its_bytecode_stale(tmp_path: Path) -> None:
    source = _module(tmp_path, "probe_stale", "X = 1\n")
    bytecode.compile_sources([source])
    source.write_text("X = 22\n")  # another size
    assert not bytecode.bytecode_is_current(source)
    cached = Path(importlib.util.cache_from_source(str(source)))
    cached.write_bytes(b"junk")  # a truncated or foreign file is not current either
    assert not bytecode.bytecode_is_current(source)


def test_the_modification_time_alone_makes_bytecode_stale(tmp_path: Path) -> None:
    source = _module(tmp_path, "probe_mtime", "X = 1\n")
    bytecode.compile_sources([source])
    stat = source.stat()
    os.utime(source, ns=(stat.st_atime_ns, stat.st_mtime_ns + 5 * 10**9))  # an edit of the same size, 5 s later
    assert not bytecode.bytecode_is_current(source)


def test_hash_based_bytecode_is_checked_as_python_checks_it(tmp_path: Path) -> None:
    source = _module(tmp_path, "probe_hash", "X = 1\n")
    checked, unchecked = py_compile.PycInvalidationMode.CHECKED_HASH, py_compile.PycInvalidationMode.UNCHECKED_HASH
    py_compile.compile(str(source), doraise=True, invalidation_mode=checked)
    assert bytecode.bytecode_is_current(source)
    source.write_text("X = 3\n")  # the same size: only the hash tells
    assert not bytecode.bytecode_is_current(source)
    assert bytecode.compile_sources(bytecode.stale_sources([source])) == 1 and bytecode.bytecode_is_current(source)
    py_compile.compile(str(source), doraise=True, invalidation_mode=unchecked)
    source.write_text("X = 4\n")
    assert bytecode.bytecode_is_current(source)  # Python never checks it either


def test_a_pycache_prefix_tree_is_made_on_writing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = _module(tmp_path, "probe_prefix", "X = 1\n")
    monkeypatch.setattr(sys, "pycache_prefix", str(tmp_path / "prefix"))
    assert bytecode.compile_sources([source]) == 1
    cached = Path(importlib.util.cache_from_source(str(source)))
    assert cached.is_relative_to(tmp_path / "prefix") and cached.is_file() and bytecode.bytecode_is_current(source)


def test_unwritable_folders_and_broken_sources_are_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    broken = _module(tmp_path, "probe_broken", "def (:\n")
    assert bytecode.compile_sources([broken]) == 0  # importing it says why; the bytecode writer does not raise
    fine = _module(tmp_path, "probe_fine", "X = 1\n")
    monkeypatch.setattr(bytecode.os, "access", lambda path, mode: False)
    assert bytecode.compile_sources([fine]) == 0
    assert not Path(importlib.util.cache_from_source(str(fine))).exists()


def test_imported_modules_are_cached_only_where_python_writes_none(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = _module(tmp_path, "probe_imported", "X = 1\n")
    probe = _import(source, "monovisual3d._bytecode_probe")
    monkeypatch.setitem(sys.modules, "monovisual3d._bytecode_probe", probe)
    compiled: list[list[str]] = []
    monkeypatch.setattr(bytecode, "compile_sources", lambda sources: compiled.append(list(sources)) or len(compiled[-1]))
    monkeypatch.setattr(sys, "dont_write_bytecode", False)
    assert bytecode.cache_imported_bytecode() == 0 and compiled == []  # Python writes it itself
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    bytecode.cache_imported_bytecode()
    assert str(source) in compiled[0]
    package = Path(bytecode.__file__).parent.parent
    assert all(p == str(source) or Path(p).is_relative_to(package) for p in compiled[0])
    monkeypatch.setenv(bytecode.WRITE_ENV, "0")  # the user's opt-out
    assert bytecode.cache_imported_bytecode() == 0 and len(compiled) == 1
    monkeypatch.delenv(bytecode.WRITE_ENV)

    def broken(sources: object) -> int:
        raise RuntimeError("a file system that misbehaves")

    monkeypatch.setattr(bytecode, "compile_sources", broken)
    assert bytecode.cache_imported_bytecode() == 0  # a cache never fails the command that ran


def test_every_command_caches_the_bytecode_it_imported(monkeypatch: pytest.MonkeyPatch) -> None:
    from monovisual3d.cli import main

    calls: list[int] = []
    monkeypatch.setattr(bytecode, "cache_imported_bytecode", lambda: calls.append(1) or 0)
    monkeypatch.setattr(sys, "argv", ["monovisual3d", "options", "bayes"])
    with pytest.raises(SystemExit) as stop:
        main()
    assert stop.value.code == 0 and calls == [1]
    monkeypatch.setattr(sys, "argv", ["monovisual3d", "localize", "no-such-session.json"])
    with pytest.raises(SystemExit) as stop:  # a refused command too
        main()
    assert stop.value.code == 2 and calls == [1, 1]


def test_the_package_sources_are_its_python_files() -> None:
    sources = bytecode.package_sources()
    assert Path(bytecode.__file__).resolve() in sources
    assert all(p.suffix == ".py" for p in sources) and sources == sorted(sources)
