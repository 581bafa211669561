"""Checks shared by the command-line tests: what a user sees when a command refuses its input."""

from __future__ import annotations

from typing import Any


def assert_one_line_error(result: Any, *fragments: str) -> str:
    """Exit code 2, one line on stderr starting with 'error:' that holds every fragment, no traceback.

    ``result`` is a :class:`typer.testing.CliRunner` result. Returns the line.
    """
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: "), lines[0]
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert "Traceback" not in result.output
    assert isinstance(result.exception, SystemExit)
    return lines[0]
