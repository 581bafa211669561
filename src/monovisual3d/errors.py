"""Errors and warnings raised for user input.

:class:`InputError` is raised for input that cannot be used; its message is a
single line naming the file (where known), the field and what was expected.
The CLI turns it into exit code 2 without a traceback.
:class:`InputWarning` flags input that is still usable, with the behaviour
that was applied (for example a box clipped to the image).
"""

from __future__ import annotations

import math
from typing import Any

#: Characters of a value quoted in a message (kept equal to ``limits.EXCERPT_CHARS``).
_EXCERPT_CHARS = 60


class InputError(ValueError):
    """Bad user input: the message names the source, the field and what was expected."""


class MissingExtra(ImportError):
    """An optional dependency is not installed: the message names the extra that provides it (a user's setup, said
    in one line by the CLI, not a bug)."""


class InputWarning(UserWarning):
    """Usable but suspicious input; the message says what was done with it."""


def prefixed(source: str | None, message: str) -> str:
    """Prefix ``message`` with ``source: `` when a source (file name) is known."""
    return f"{source}: {message}" if source else message


def one_line(text: str, limit: int | None = None) -> str:
    """``text`` with control characters (newlines, terminal escapes) written as escapes, optionally cut to ``limit``.

    Examples
    --------
    >>> one_line("a\\nb\\x1b[31m")
    'a\\\\nb\\\\x1b[31m'
    """
    if text.isprintable():
        out = text
    else:
        out = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)
    if limit is not None and len(out) > limit:
        out = out[: limit - 3] + "..."
    return out


def excerpt(value: Any, limit: int = _EXCERPT_CHARS) -> str:
    """A bounded, one-line ``repr`` of ``value`` for error messages.

    Never builds the full ``repr`` of a large (or alias-expanded, or self-referencing)
    structure: lists and dicts are walked only until ``limit`` characters are written.

    Examples
    --------
    >>> excerpt(list(range(1000)), 20)
    '[0, 1, 2, 3, 4, 5...'
    >>> excerpt(10**400)
    'an integer of 401 digits'
    """
    parts: list[str] = []
    budget = [limit + 1]

    def put(text: str) -> bool:
        parts.append(text[: budget[0]])
        budget[0] -= len(text)
        return budget[0] > 0

    def walk(v: Any, depth: int) -> bool:
        if depth > 8:
            return put("...")
        if isinstance(v, list | tuple):
            if not put("[" if isinstance(v, list) else "("):
                return False
            for i, item in enumerate(v):
                if (i and not put(", ")) or not walk(item, depth + 1):
                    return False
            return put("]" if isinstance(v, list) else ")")
        if isinstance(v, dict):
            if not put("{"):
                return False
            for i, (key, item) in enumerate(v.items()):
                if (i and not put(", ")) or not walk(key, depth + 1) or not put(": ") or not walk(item, depth + 1):
                    return False
            return put("}")
        if isinstance(v, int) and not isinstance(v, bool) and abs(v) > 10**30:
            digits = int(math.log10(abs(v))) + 1 if abs(v) < 10**4000 else "over 4000"
            return put(f"an integer of {digits} digits")
        if isinstance(v, str | bytes) and len(v) > limit:
            v = v[: limit + 1]
            return put(repr(v)[:-1])
        try:
            text = repr(v)
        except Exception:  # noqa: BLE001 - a value whose repr fails is still named by type
            text = f"<{type(v).__name__}>"
        return put(text)

    walk(value, 0)
    text = one_line("".join(parts))
    return text if len(text) <= limit else text[: limit - 3] + "..."
