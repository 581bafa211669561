"""Finding the sessions of a batch: files, folders (searched recursively) and globs."""

from __future__ import annotations

import glob
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError

#: File names a folder is searched for (recursively).
SESSION_NAMES = ("session.json", "session.yaml", "session.yml")
#: Ground truth looked for beside each session.
TRUTH_NAME = "truth.json"
#: Files a glob may match beside sessions that are not sessions (ground truth, the simulator's scene).
COMPANION_NAMES = (TRUTH_NAME, "scene.json")
#: Suffixes of the session files a glob may match.
SESSION_SUFFIXES = (".json", ".yaml", ".yml")


@dataclass(frozen=True)
class SessionInput:
    """One session of a batch.

    Attributes
    ----------
    path : Path, absolute path of the session file
    session_id : str, the path relative to the common folder of all inputs, with ``/`` separators
    truth_path : Path or None, ``truth.json`` beside the session when there is one
    """

    path: Path
    session_id: str
    truth_path: Path | None


def _has_magic(text: str) -> bool:
    return any(c in text for c in "*?[")


def _glob_root(pattern: str) -> Path:
    """The folder a glob searches from: its leading components without wildcards."""
    parts = Path(pattern).parts
    fixed = []
    for part in parts:
        if _has_magic(part):
            break
        fixed.append(part)
    return Path(*fixed) if fixed else Path(".")


def _abs(path: Path) -> Path:
    """Absolute and normalised (``..`` removed), symbolic links kept."""
    return Path(os.path.abspath(path))


def _session_files(folder: Path) -> list[Path]:
    return sorted(p for name in SESSION_NAMES for p in folder.rglob(name) if p.is_file())


def find_sessions(inputs: Sequence[str | Path]) -> list[SessionInput]:
    """The sessions named by ``inputs``, sorted by id, each once.

    Parameters
    ----------
    inputs : sequence of str or Path
        Session files (any name), folders (searched recursively for
        ``session.json``, ``session.yaml``, ``session.yml``) and globs
        (``runs/*/session.json``, ``runs/**``; a matched folder is searched, and of
        the matched files those ending in .json/.yaml/.yml are sessions except
        ``truth.json`` and ``scene.json``).

    Returns
    -------
    list of SessionInput
        Ids are paths relative to the deepest folder that holds all the inputs
        (a folder input counts as itself, a file as its folder), so
        ``batch runs/`` and ``batch runs/*/session.json`` give the same ids.

    Raises
    ------
    InputError
        When ``inputs`` is empty, names something that does not exist, a glob
        matches nothing, or a folder holds no session.

    Examples
    --------
    >>> from monovisual3d.examples import example_session_path
    >>> [s.session_id for s in find_sessions([example_session_path()])]
    ['single_sphere_session.json']
    """
    if isinstance(inputs, (str, Path)):
        inputs = [inputs]
    if not inputs:
        raise InputError("inputs: empty, expected session files, folders or globs")
    files: dict[Path, None] = {}
    roots: list[Path] = []
    for item in inputs:
        text = str(item)
        if _has_magic(text) and not Path(text).exists():  # an existing path is taken as written, "[" and all
            matches = [Path(m) for m in sorted(glob.glob(text, recursive=True))]
            if not matches:
                raise InputError(f"{text}: matched no file or folder")
            roots.append(_abs(_glob_root(text)))
            for m in matches:
                if m.is_file() and (m.name in COMPANION_NAMES or m.suffix.lower() not in SESSION_SUFFIXES):
                    continue
                for f in _session_files(m) if m.is_dir() else [m]:
                    files[_abs(f)] = None
            continue
        path = Path(text)
        if not path.exists():
            raise InputError(f"{text}: no such file or folder")
        if path.is_dir():
            found = _session_files(path)
            if not found:
                raise InputError(f"{text}: no {' or '.join(SESSION_NAMES)} in this folder or below")
            roots.append(_abs(path))
            for f in found:
                files[_abs(f)] = None
        else:
            roots.append(_abs(path).parent)
            files[_abs(path)] = None
    if not files:
        raise InputError(f"{', '.join(map(str, inputs))}: no session file found")
    root = Path(os.path.commonpath([str(r) for r in roots] + [str(f.parent) for f in files]))
    out = []
    for f in files:
        truth = f.parent / TRUTH_NAME
        out.append(SessionInput(f, f.relative_to(root).as_posix(), truth if truth.is_file() and truth != f else None))
    return sorted(out, key=lambda s: s.session_id)
