"""What an import produced and what it skipped, and why.

Nothing is dropped silently: every view or detection an importer leaves out is
recorded here with its reason, and views left out for a data problem (no pose
close enough in time, a missing transform) are also reported as an
:class:`~monovisual3d.errors.InputWarning`.
"""

from __future__ import annotations

import warnings
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputWarning
from ..session import Session


@dataclass(frozen=True)
class Skipped:
    """One item left out of the session.

    Attributes
    ----------
    kind : {"view", "detection", "image"}
    item : str, which one (image name, stamp, file:line)
    reason : str, the general reason (used to group the summary)
    detail : str, specifics (numbers) for this item
    """

    kind: str
    item: str
    reason: str
    detail: str = ""

    def __str__(self) -> str:
        return f"{self.kind} {self.item}: {self.reason}" + (f" ({self.detail})" if self.detail else "")


@dataclass
class ImportSummary:
    """Counts of what was imported and the list of what was skipped.

    Attributes
    ----------
    source : str, what was imported (file names)
    n_views, n_detections : int, in the session
    n_empty_views : int, views kept without detections
    skipped : list of Skipped
    notes : list of str, choices the importer made (e.g. "matched by file name")
    time_offset : dict or None, ``import --time-offset auto``'s estimate: ``offset_s``, ``determined``, ``frame_s``
    """

    source: str = ""
    n_views: int = 0
    n_detections: int = 0
    n_empty_views: int = 0
    skipped: list[Skipped] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    time_offset: dict[str, Any] | None = None

    def skip(self, kind: str, item: str, reason: str, detail: str = "", *, warn: bool = True) -> None:
        """Record a skipped item; ``warn`` also issues an InputWarning (for data problems, not filters)."""
        entry = Skipped(kind, item, reason, detail)
        self.skipped.append(entry)
        if warn:
            prefix = f"{self.source}: " if self.source else ""
            warnings.warn(InputWarning(f"{prefix}skipped {entry}"), stacklevel=3)

    def note(self, text: str) -> None:
        self.notes.append(text)

    def count_session(self, session: Session) -> None:
        self.n_views = len(session.views)
        self.n_detections = sum(len(v.detections) for v in session.views)
        self.n_empty_views = sum(1 for v in session.views if not v.detections)

    def reasons(self) -> dict[tuple[str, str], int]:
        """Number of skipped items per ``(kind, reason)``."""
        return dict(Counter((s.kind, s.reason) for s in self.skipped))

    def lines(self, examples: int = 3) -> list[str]:
        """Human-readable summary, one line per fact."""
        out = [f"views: {self.n_views} ({self.n_empty_views} without detections)", f"detections: {self.n_detections}"]
        for (kind, reason), n in sorted(self.reasons().items(), key=lambda kv: (-kv[1], kv[0])):
            items = [s.item for s in self.skipped if s.kind == kind and s.reason == reason]
            shown = ", ".join(items[:examples]) + (", ..." if len(items) > examples else "")
            out.append(f"skipped {n} {kind}{'s' if n != 1 else ''}: {reason} [{shown}]")
        out.extend(f"note: {n}" for n in self.notes)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "views": self.n_views,
            "detections": self.n_detections,
            "empty_views": self.n_empty_views,
            "skipped": [{"kind": s.kind, "item": s.item, "reason": s.reason, "detail": s.detail} for s in self.skipped],
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class ImportResult:
    """A validated session and the summary of how it was built."""

    session: Session
    summary: ImportSummary
