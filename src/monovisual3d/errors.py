"""Errors and warnings raised for user input.

:class:`InputError` is raised for input that cannot be used; its message is a
single line naming the file (where known), the field and what was expected.
The CLI turns it into exit code 2 without a traceback.
:class:`InputWarning` flags input that is still usable, with the behaviour
that was applied (for example a box clipped to the image).
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad user input: the message names the source, the field and what was expected."""


class InputWarning(UserWarning):
    """Usable but suspicious input; the message says what was done with it."""


def prefixed(source: str | None, message: str) -> str:
    """Prefix ``message`` with ``source: `` when a source (file name) is known."""
    return f"{source}: {message}" if source else message
