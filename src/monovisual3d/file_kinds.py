"""Recognise the project's own files by their top-level keys, to say so when one is given in place of another.

Each command reads one kind of file; a newcomer easily gives ``localize`` the
``truth.json`` that ``simulate`` wrote beside the session. The loaders call
:func:`wrong_kind` only when the file has already failed their own check, so
recognising costs nothing on the good path and changes no valid input.

Examples
--------
>>> wrong_kind({"objects": [], "views": [], "noise": {}, "scene": "paper"}, expected="session")
'this is a truth file (written by simulate), not a session; give it to evaluate (or view --truth)'
>>> wrong_kind({"camera": {}, "views": []}, expected="session") is None
True
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class FileKind:
    """One kind of project file: its name, a test on its top-level keys, what it is and where it goes."""

    name: str
    test: Callable[[set[str]], bool]
    what: str
    where: str


#: The kinds recognised, first match wins (the specific kinds come first).
KINDS = (
    FileKind(
        "result",
        lambda k: {"objects", "method"} <= k and bool(k & {"config", "grid", "timing_s"}),
        "a result file (written by localize --output)",
        "give it to evaluate (or view --result)",
    ),
    FileKind(
        "truth",
        lambda k: "objects" in k and bool(k & {"noise", "scene"}),
        "a truth file (written by simulate)",
        "give it to evaluate (or view --truth)",
    ),
    FileKind(
        "scene", lambda k: {"objects", "occluders"} <= k, "a scene file (written by simulate)", "give it to simulate --scene"
    ),
    FileKind(
        "session",
        lambda k: {"camera", "views"} <= k,
        "a session file (camera, poses and boxes)",
        "localize it first: monovisual3d localize SESSION -o result.json",
    ),
    FileKind(
        "metrics",
        lambda k: {"euclidean_mean", "recall", "precision"} <= k,
        "a metrics file (written by evaluate --output)",
        "it is a report: no command reads it back",
    ),
    FileKind(
        "plan",
        lambda k: {"ranking", "done"} <= k,
        "a next-view plan (written by next-view)",
        "move the camera to its pose, then add that view to the session",
    ),
    FileKind(
        "batch summary",
        lambda k: {"n_ok", "n_error", "n_fruit"} <= k,
        "a batch summary (summary.json written by batch)",
        "give batch the session files or their folders",
    ),
    FileKind(
        "poses",
        lambda k: "poses" in k and not k & {"camera", "objects"},
        "a list of poses (next-view --candidates or simulate --views)",
        "give it to next-view --candidates or simulate --views",
    ),
)
#: What each command expects, in the words of the message.
EXPECTED = {"session": "a session", "objects": "a result or truth file"}


def kind_of(data: Any) -> str | None:
    """The kind of a parsed project file from its top-level keys (``"truth"``, ``"result"``, ...), or None."""
    if isinstance(data, list) and data and all(isinstance(d, dict) and {"matrix", "position"} & set(d) for d in data):
        return "poses"  # a bare list of poses (simulate --views, or 4x4 matrices)
    if not isinstance(data, dict):
        return None
    keys = {k for k in data if isinstance(k, str)}
    return next((kind.name for kind in KINDS if kind.test(keys)), None)


def wrong_kind(data: Any, expected: str) -> str | None:
    """One line saying what ``data`` is and where it goes, when it is a known kind other than ``expected``.

    Parameters
    ----------
    data : parsed JSON/YAML of the file
    expected : ``"session"`` or ``"objects"`` (a result or truth file)

    Returns
    -------
    str or None, e.g. ``"this is a truth file (written by simulate), not a session; give it to evaluate"``
    """
    kind = kind_of(data)
    accepted = {"session": ("session",), "objects": ("result", "truth")}[expected]
    if kind is None or kind in accepted:
        return None
    found = next(k for k in KINDS if k.name == kind)
    return f"this is {found.what}, not {EXPECTED[expected]}; {found.where}"


#: Files that are not JSON or YAML at all, by their suffix: what they are and where they go.
SUFFIX_KINDS = {
    ".csv": "a CSV table (batch writes fruit.csv and sessions.csv); read it with a spreadsheet or pandas",
    ".parquet": "a Parquet table (written by batch); read it with pandas or pyarrow",
    ".png": "an image; a session lists the detector's boxes, not the pictures (see monovisual3d import)",
    ".jpg": "an image; a session lists the detector's boxes, not the pictures (see monovisual3d import)",
    ".jpeg": "an image; a session lists the detector's boxes, not the pictures (see monovisual3d import)",
    ".html": "a page written by view or demo; open it in a web browser",
    ".npy": "a numpy array (the LfD layout: give its folder to monovisual3d import-lfd)",
    ".bag": "a ROS bag; convert it with monovisual3d import-bag",
    ".db3": "a ROS 2 bag file; convert its folder with monovisual3d import-bag",
    ".mcap": "a ROS 2 bag file; convert its folder with monovisual3d import-bag",
}


def kind_by_suffix(name: str) -> str | None:
    """What a file that failed to parse as JSON/YAML probably is, from its suffix (None when the suffix says nothing).

    Examples
    --------
    >>> kind_by_suffix("results/fruit.parquet")
    'this looks like a Parquet table (written by batch); read it with pandas or pyarrow'
    >>> kind_by_suffix("session.json") is None
    True
    """
    suffix = name[name.rfind(".") :].lower() if "." in name.rsplit("/", 1)[-1] else ""
    what = SUFFIX_KINDS.get(suffix)
    return None if what is None else f"this looks like {what}"
