"""Reading JSON and YAML input files safely: strict UTF-8, bounded size, nesting and aliases.

Every function raises :class:`~monovisual3d.errors.InputError` with one line
``FILE: problem`` (``FILE: json.path: problem`` where a field is at fault) for
malformed or hostile content, never another exception:

- bytes that are not UTF-8 are refused (not replaced);
- duplicate keys are refused (JSON: with the key's path; YAML: with its line);
- nesting deeper than :data:`~monovisual3d.limits.MAX_NESTING` is refused;
- YAML aliases may share values, but the document with aliases expanded may hold
  at most :data:`~monovisual3d.limits.MAX_NODES` values (no "billion laughs"),
  and recursive aliases are refused;
- YAML tags (``!!python/object``, ``!!binary``, ``!custom`` ...) are refused, except
  OpenCV's ``!!opencv-*`` where a reader of calibration files allows them.
"""

from __future__ import annotations

import json
import re
import stat
from pathlib import Path
from typing import Any

import yaml

from .errors import InputError, excerpt, one_line
from .file_kinds import kind_by_suffix
from .limits import MAX_FILE_BYTES, MAX_NESTING, MAX_NODES, MAX_YAML_BYTES, MAX_YAML_NODES


def read_capped_bytes(path: str | Path, limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes, with a one-line error otherwise.

    Devices (``/dev/zero``), FIFOs and sockets are refused before they are opened
    (reading them has no end, or blocks), and at most ``limit + 1`` bytes are ever
    read (a file that grows while it is read is refused, not read without bound).
    """
    path = Path(path)
    name = one_line(str(path))
    try:
        if not path.exists():
            raise InputError(f"{name}: file not found")
        info = path.stat()
        if stat.S_ISDIR(info.st_mode):
            raise InputError(f"{name}: is a directory, expected a file")
        if not stat.S_ISREG(info.st_mode):
            raise InputError(f"{name}: is a {_file_kind(info.st_mode)}, expected a regular file")
        if info.st_size > limit:
            raise InputError(f"{name}: {info.st_size} bytes, larger than the {limit} bytes accepted")
        with open(path, "rb") as f:
            raw = f.read(limit + 1)
    except OSError as exc:
        raise InputError(f"{name}: cannot read ({exc.strerror or type(exc).__name__})") from None
    if len(raw) > limit:  # it grew while it was read
        raise InputError(f"{name}: larger than the {limit} bytes accepted")
    return raw


def _file_kind(mode: int) -> str:
    """What a non-regular file is, in words (for errors)."""
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "device"
    if stat.S_ISFIFO(mode):
        return "FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "socket"
    return "special file"


def read_text(path: str | Path) -> str:
    """Read a UTF-8 text file (a BOM is allowed) with a one-line error for missing, directory, binary or huge files.

    Devices and FIFOs are refused (see :func:`read_capped_bytes`).
    """
    name = one_line(str(path))
    raw = read_capped_bytes(path)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        hint = kind_by_suffix(str(path))
        raise InputError(
            f"{name}: " + (hint if hint else f"not UTF-8 text (invalid byte 0x{raw[exc.start]:02x} at offset {exc.start})")
        ) from None
    if "\x00" in text:
        raise InputError(f"{name}: contains NUL bytes, expected a text file")
    return text


# ---------------------------------------------------------------------- JSON
class _Duplicated(dict):  # type: ignore[type-arg]
    """An object that had a duplicate key (reported with its path by :func:`check_tree`)."""

    duplicate: Any = None


def _pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        seen: set[str] = set()
        dup = next(k for k, _ in pairs if k in seen or seen.add(k))  # type: ignore[func-returns-value]
        marked = _Duplicated(out)
        marked.duplicate = dup
        return marked
    return out


def load_json(text: str, source: str) -> Any:
    """Parse JSON text: duplicate keys, deep nesting and numbers with thousands of digits are one-line errors."""
    source = one_line(source)
    try:
        data = json.loads(text, object_pairs_hook=_pairs)
    except json.JSONDecodeError as exc:
        hint = kind_by_suffix(source)
        if hint:
            raise InputError(f"{source}: not JSON: {hint}") from None
        raise InputError(f"{source}: not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise InputError(f"{source}: not valid JSON: nested deeper than {MAX_NESTING} levels") from None
    except ValueError as exc:  # e.g. an integer with more than 4300 digits
        raise InputError(f"{source}: not valid JSON: {one_line(str(exc), 120)}") from None
    check_tree(data, source)
    return data


# ---------------------------------------------------------------------- YAML
class _ComposeLimit(yaml.YAMLError):
    def __init__(self, problem: str, mark: Any) -> None:
        super().__init__(problem)
        self.problem = problem
        self.problem_mark = mark


class SafeLoader(yaml.SafeLoader):
    """PyYAML's safe loader with bounded nesting, no duplicate keys and no tags.

    Floats without a dot (``1e-05``) are numbers, as in YAML 1.2 (PyYAML's YAML 1.1
    reads them as text).
    """

    allow_tag_prefixes: tuple[str, ...] = ()

    def __init__(self, stream: Any) -> None:
        super().__init__(stream)
        self._depth = 0
        self._nodes = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        tag = getattr(event, "tag", None)
        if (
            isinstance(event, (yaml.ScalarEvent, yaml.SequenceStartEvent, yaml.MappingStartEvent))
            and tag not in (None, "!")
            and not (isinstance(event, yaml.ScalarEvent) and event.implicit[0])
            and not tag.startswith(self.allow_tag_prefixes or ("\0",))
        ):
            raise _ComposeLimit(f"tag {excerpt(tag)} is not accepted (YAML tags are not supported)", event.start_mark)
        self._depth += 1
        self._nodes += 1
        if self._nodes > MAX_YAML_NODES:
            raise _ComposeLimit(
                f"more than {MAX_YAML_NODES:,} values, the most a YAML file may hold (use JSON)", event.start_mark
            )
        if self._depth > MAX_NESTING:
            raise _ComposeLimit(f"nested deeper than {MAX_NESTING} levels", event.start_mark)
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen: set[Any] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=True)
                try:
                    dup = key in seen
                    seen.add(key)
                except TypeError:  # an unhashable key: PyYAML reports it below
                    continue
                if dup:
                    raise _ComposeLimit(f"duplicate key {excerpt(key)}", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


SafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def load_yaml(text: str, source: str, loader: type[SafeLoader] = SafeLoader) -> Any:
    """Parse YAML text with ``loader`` (a :class:`SafeLoader`); malformed or hostile content is a one-line error."""
    source = one_line(source)
    if len(text) > MAX_YAML_BYTES:
        raise InputError(f"{source}: {len(text)} characters, larger than the {MAX_YAML_BYTES} accepted in YAML (use JSON)")
    try:
        data = yaml.load(text, Loader=loader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise InputError(f"{source}: not valid YAML{where}: {one_line(str(problem), 120)}") from None
    except RecursionError:
        raise InputError(f"{source}: not valid YAML: nested deeper than {MAX_NESTING} levels") from None
    except (ValueError, TypeError, OverflowError) as exc:  # PyYAML constructors on odd scalars (dates ...)
        raise InputError(f"{source}: not valid YAML: {one_line(str(exc), 120)}") from None
    check_tree(data, source)
    return data


def load_structured(path: str | Path, loader: type[SafeLoader] = SafeLoader) -> Any:
    """Read a JSON or YAML file: ``.yaml``/``.yml`` is YAML, anything else JSON."""
    text = read_text(path)
    if Path(path).suffix.lower() in (".yaml", ".yml"):
        return load_yaml(text, str(path), loader)
    return load_json(text, str(path))


# ---------------------------------------------------------------------- tree limits
def _path(frames: list[list[Any]]) -> str:
    out = ""
    for frame in frames[1:]:
        key = frame[3]
        out += f"[{key}]" if isinstance(key, int) else f".{one_line(str(key), 40)}"
    return out.lstrip(".") or "(top level)"


def check_tree(data: Any, source: str) -> int:
    """Check a parsed document's nesting depth, size (shared values counted each time) and duplicate keys.

    Returns the number of values with aliases expanded. Walks each shared
    (aliased) value once, so a YAML alias bomb costs its file size, not its
    expansion.
    """
    if not isinstance(data, (list, dict)):
        return 1
    sizes: dict[int, int] = {}
    on_path: set[int] = set()

    def children(obj: Any) -> Any:
        return iter(obj.items()) if isinstance(obj, dict) else enumerate(obj)

    # frame: [object, children iterator, expanded size so far, key in the parent]
    frames: list[list[Any]] = [[data, children(data), 1, None]]
    on_path.add(id(data))
    total = 0
    while frames:
        frame = frames[-1]
        obj = frame[0]
        if isinstance(obj, _Duplicated) and frame[2] == 1:
            where = _path(frames)
            key = one_line(str(obj.duplicate), 40)
            path = f"{key}" if where == "(top level)" else f"{where}.{key}"
            raise InputError(f"{source}: {path}: duplicate key, each key may appear once")
        for key, child in frame[1]:
            if isinstance(child, (list, dict)):
                cid = id(child)
                if cid in sizes:
                    frame[2] += sizes[cid]
                elif cid in on_path:
                    raise InputError(f"{source}: {_path([*frames, [None, None, 0, key]])}: refers to itself (recursive alias)")
                else:
                    if len(frames) >= MAX_NESTING:
                        raise InputError(f"{source}: {_path(frames)}: nested deeper than {MAX_NESTING} levels")
                    frames.append([child, children(child), 1, key])
                    on_path.add(cid)
                    break
            else:
                frame[2] += 1
            if frame[2] > MAX_NODES:
                raise InputError(
                    f"{source}: {_path(frames)}: more than {MAX_NODES:,} values (YAML aliases expanded), the most accepted"
                )
        else:
            frames.pop()
            on_path.discard(id(obj))
            sizes[id(obj)] = frame[2]
            if frames:
                frames[-1][2] += frame[2]
                if frames[-1][2] > MAX_NODES:
                    raise InputError(
                        f"{source}: {_path(frames)}: more than {MAX_NODES:,} values (YAML aliases expanded), the most accepted"
                    )
            else:
                total = frame[2]
    return total


def read_structured_file(path: str | Path) -> Any:
    """Read JSON or YAML (by suffix) with a one-line error for malformed or hostile content.

    Strict UTF-8, no duplicate keys, bounded size, nesting and YAML aliases, no YAML
    tags (see :mod:`monovisual3d.limits`).
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{one_line(str(path))}: is a directory, expected a JSON or YAML file")
    return load_structured(path)


def parse_structured_text(text: str, path: str | Path) -> Any:
    """Parse JSON or YAML text read from ``path`` (YAML by suffix), with the checks and errors of :func:`read_structured_file`."""
    if Path(path).suffix.lower() in (".yaml", ".yml"):
        return load_yaml(text, str(path))
    return load_json(text, str(path))
