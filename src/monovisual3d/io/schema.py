"""The session file's published JSON Schema (``monovisual3d/schemas/session.schema.json``).

The loader (:func:`monovisual3d.load_session`) is what validates sessions and
words the errors; the schema documents the same structure for other tools
(editors, other languages). Tests check that the two agree: every document the
loader accepts satisfies the schema, and structural errors are rejected by both.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from .._extras import require


def session_schema_path() -> Path:
    """Path of ``session.schema.json`` inside the installed package."""
    return Path(str(resources.files("monovisual3d") / "schemas" / "session.schema.json"))


@cache
def _schema_text() -> str:
    return session_schema_path().read_text(encoding="utf-8")


def session_schema() -> dict[str, Any]:
    """The session JSON Schema (draft 2020-12) as a dict (a fresh copy).

    Examples
    --------
    >>> session_schema()["required"]
    ['camera', 'views']
    """
    return json.loads(_schema_text())


def validate_session_schema(data: Any) -> list[str]:
    """Schema errors of a parsed session, as ``json.path: message`` lines (empty when valid).

    Needs the ``jsonschema`` package (in the ``[dev]`` extra).

    Examples
    --------
    >>> validate_session_schema({"camera": {"width": 640, "height": 480, "hfov_deg": 69}, "views": []})
    ['views: [] should be non-empty']
    """
    jsonschema = require("jsonschema", "dev")
    validator = jsonschema.Draft202012Validator(session_schema())
    out = []
    for err in sorted(validator.iter_errors(data), key=lambda e: list(map(str, e.absolute_path))):
        path = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in err.absolute_path).lstrip(".") or "(top level)"
        out.append(f"{path}: {err.message}")
    return out


__all__ = ["session_schema", "session_schema_path", "validate_session_schema"]
