"""Fixtures of the io tests: the hand-written fixture files and a strict warnings policy."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from monovisual3d.errors import InputError, InputWarning

FIXTURES = Path(__file__).parent / "fixtures"


@pytest.fixture
def fixtures() -> Path:
    """Folder of the hand-written files in the real formats."""
    return FIXTURES


@pytest.fixture
def strict_warnings() -> Iterator[None]:
    """Any warning other than InputWarning (e.g. a numpy RuntimeWarning) fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", InputWarning)
        yield


def outcome(fn: Callable[[], Any]) -> tuple[str, Any]:
    """Run ``fn``: ``("ok", value)`` or ``("input_error", message)``; any other exception propagates.

    Warnings other than InputWarning are turned into errors, so sloppy numerics
    (overflow, invalid values) fail the property tests too.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", InputWarning)
        try:
            return "ok", fn()
        except InputError as exc:
            message = str(exc)
            assert message and "\n" not in message, f"InputError messages are one line: {message!r}"
            return "input_error", message
