"""Finding the sessions of a batch: files, folders (searched recursively) and globs."""

from __future__ import annotations

import fnmatch
import os
import re
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError, one_line

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
    error : str or None, why this entry cannot be read (an unreadable folder): the batch records it as a failed row
    """

    path: Path
    session_id: str
    truth_path: Path | None
    error: str | None = None


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


class _Walk:
    """A walk of folders that follows links to folders but visits each real folder once (no symlink loops).

    Attributes
    ----------
    paths : list of Path, every file and folder found below the roots (as reached, links kept in the path)
    unreadable : dict, folder -> one-line reason, for folders that could not be listed
    """

    def __init__(self) -> None:
        self.seen: set[tuple[int, int]] = set()
        self.paths: list[Path] = []
        self.unreadable: dict[Path, str] = {}

    def walk(self, folder: Path) -> None:
        """Add the paths below ``folder``; folders reached through a link are walked after all the others,
        so a file reachable both ways is listed under its path without links."""
        stack, linked = [folder], []
        while stack or linked:
            d = stack.pop() if stack else linked.pop()
            try:
                info = d.stat()
                key = (info.st_dev, info.st_ino)
                if key in self.seen:
                    continue
                self.seen.add(key)
                entries = sorted(os.scandir(d), key=lambda e: e.name)
            except OSError as exc:
                self.unreadable[d] = f"cannot read folder ({exc.strerror or type(exc).__name__})"
                continue
            subdirs, links = [], []
            for e in entries:
                path = d / e.name
                self.paths.append(path)
                try:
                    if e.is_dir():  # follows links; the seen set stops loops
                        (links if e.is_symlink() else subdirs).append(path)
                except OSError:
                    continue
            stack.extend(reversed(subdirs))
            linked[:0] = reversed(links)  # first found, first walked


def _session_files(folder: Path, walk: _Walk | None = None) -> list[Path]:
    """Session files (by name) in ``folder`` and below; unreadable folders are noted in ``walk``."""
    walk = walk if walk is not None else _Walk()
    start = len(walk.paths)
    walk.walk(folder)
    return sorted(p for p in walk.paths[start:] if p.name in SESSION_NAMES and p.is_file())


def _component_regex(part: str) -> re.Pattern[str]:
    return re.compile(fnmatch.translate(part), re.DOTALL)


def _glob(pattern: str, walk: _Walk) -> list[Path]:
    """Paths matching ``pattern`` (``**`` matches any number of folders), found by a walk that visits each
    real folder once, so links to ``.`` or to a parent end instead of looping.

    Hidden names match ``*`` as in :func:`glob.glob`: only when the pattern component starts with a dot.
    """
    root = _glob_root(pattern)
    parts = Path(pattern).parts[len(root.parts) :]
    regexes = [None if p == "**" else _component_regex(p) for p in parts]
    start = len(walk.paths)
    if root.is_dir():
        walk.walk(root)
    out = []
    for path in walk.paths[start:]:
        rel = path.relative_to(root).parts
        if _match(rel, regexes, [p.startswith(".") for p in parts]):
            out.append(path)
    return sorted(out)


def _match(names: tuple[str, ...], regexes: list[re.Pattern[str] | None], dotted: list[bool]) -> bool:
    """Whether path components ``names`` match the pattern components (``None`` is ``**``)."""
    memo: dict[tuple[int, int], bool] = {}

    def go(i: int, j: int) -> bool:
        if (i, j) in memo:
            return memo[i, j]
        if j == len(regexes):
            ok = i == len(names)
        elif regexes[j] is None:
            ok = go(i, j + 1) or (i < len(names) and not names[i].startswith(".") and go(i + 1, j))
        else:
            rx = regexes[j]
            ok = (
                i < len(names)
                and (dotted[j] or not names[i].startswith("."))
                and rx is not None
                and rx.match(names[i]) is not None
                and go(i + 1, j + 1)
            )
        memo[i, j] = ok
        return ok

    return go(0, 0)


def _real(path: Path) -> Path:
    """The file a path points to, links resolved: the key that counts each session once."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):  # a link loop
        return _abs(path)


def _check_regular(path: Path, text: str) -> None:
    """Refuse a device, FIFO or socket named as an input (reading it has no end, or blocks)."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return  # unreadable: a failed row when it is read
    if not stat.S_ISREG(mode):
        raise InputError(f"{one_line(text)}: is not a regular file (a device, FIFO or socket), expected a session file")


def find_sessions(inputs: Sequence[str | Path]) -> list[SessionInput]:
    """The sessions named by ``inputs``, sorted by id, each once.

    Parameters
    ----------
    inputs : sequence of str or Path
        Session files (any name), folders (searched recursively for
        ``session.json``, ``session.yaml``, ``session.yml``) and globs
        (``runs/*/session.json``, ``runs/**``; a matched folder is searched, and of
        the matched files those ending in .json/.yaml/.yml are sessions except
        ``truth.json`` and ``scene.json``). Links to folders are followed, each real folder once (no
        loops), and a file reached several ways is one session, under its path without links.

    Returns
    -------
    list of SessionInput
        An unreadable folder is an entry with ``error`` set (a failed row of the batch, id ``FOLDER/``).
        Ids are paths relative to the deepest folder that holds all the inputs
        (a folder input counts as itself, a file as its folder), so
        ``batch runs/`` and ``batch runs/*/session.json`` give the same ids.

    Raises
    ------
    InputError
        When ``inputs`` is empty, names something that does not exist, a glob
        matches nothing, a folder holds no session, or a device, FIFO or socket is named as an input.

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
    files: dict[Path, Path] = {}  # real path -> the path as reached (each file once, however many links lead to it)
    roots: list[Path] = []
    unreadable: dict[Path, str] = {}

    def add(found: list[Path]) -> None:
        for f in found:
            files.setdefault(_real(f), _abs(f))

    for item in inputs:
        text = str(item)
        if _has_magic(text) and not Path(text).exists():  # an existing path is taken as written, "[" and all
            add(_glob_sessions(text, unreadable))
            roots.append(_abs(_glob_root(text)))
            continue
        found, root = _path_sessions(text, unreadable)
        roots.append(root)
        add(found)
    if not files and not unreadable:
        raise InputError(f"{one_line(', '.join(map(str, inputs)))}: no session file found")
    return _session_inputs(list(files.values()), roots, unreadable)


def _path_sessions(text: str, unreadable: dict[Path, str]) -> tuple[list[Path], Path]:
    """The session files a path names (itself, or those in the folder and below) and the folder their ids start from."""
    path = Path(text)
    if not path.exists():
        raise InputError(f"{one_line(text)}: no such file or folder")
    if not path.is_dir():
        _check_regular(path, text)
        return [path], _abs(path).parent
    before = len(unreadable)
    found = _folder_sessions(path, unreadable)
    if not found and len(unreadable) == before:
        raise InputError(f"{one_line(text)}: no {' or '.join(SESSION_NAMES)} in this folder or below")
    return found, _abs(path)


def _glob_sessions(pattern: str, unreadable: dict[Path, str]) -> list[Path]:
    """The session files a glob names: matched session files, and the sessions in matched folders (each folder once)."""
    walk = _Walk()
    matches = _glob(pattern, walk)
    unreadable.update(walk.unreadable)
    if not matches and not walk.unreadable:
        raise InputError(f"{one_line(pattern)}: matched no file or folder")
    found: list[Path] = []
    searched: set[Path] = set()
    for m in matches:
        if m.is_dir():
            if not any(parent in searched for parent in m.parents):
                searched.add(m)
                found.extend(_folder_sessions(m, unreadable))
        elif m.name not in COMPANION_NAMES and m.suffix.lower() in SESSION_SUFFIXES:
            found.append(m)
    return found


def _folder_sessions(folder: Path, unreadable: dict[Path, str]) -> list[Path]:
    walk = _Walk()
    found = _session_files(folder, walk)
    unreadable.update({_abs(k): v for k, v in walk.unreadable.items()})
    return found


def _session_inputs(files: list[Path], roots: list[Path], unreadable: dict[Path, str]) -> list[SessionInput]:
    """The :class:`SessionInput` of each file and unreadable folder, ids relative to their common folder."""
    bad = {_abs(k): v for k, v in unreadable.items()}
    root = Path(os.path.commonpath([str(r) for r in roots] + [str(f.parent) for f in files] + [str(d) for d in bad]))
    out = []
    for f in files:
        truth = f.parent / TRUTH_NAME
        out.append(SessionInput(f, f.relative_to(root).as_posix(), truth if truth.is_file() and truth != f else None))
    for d, reason in bad.items():
        out.append(SessionInput(d, d.relative_to(root).as_posix() + "/", None, error=f"{one_line(str(d))}: {reason}"))
    return sorted(out, key=lambda s: s.session_id)
