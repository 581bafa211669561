"""What a result says of its own trustworthiness: named causes and a session verdict.

Every front end (``localize``, :func:`monovisual3d.localize`, the live localizer, ``batch``, ``next-view``, the ROS 2
node) carries the same :class:`Cause` list and :func:`verdict_of` it. A cause is found by a physical test on the input
(the session's own geometry) or on the fit (residuals against the sensor model); its message names the mistake and
says what to check.

Verdicts, in order of severity:

- ``ok``: nothing found wrong; the covariance covers the error as the sensor model and the residuals say;
- ``suspect``: a test fired; the answer is given, its covariance inflated where the residuals say so;
- ``unreliable``: the input is inconsistent with itself; do not act on the answer.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

#: Verdicts, least severe first.
VERDICTS: tuple[str, ...] = ("ok", "suspect", "unreliable")

#: The causes a diagnosis may name: ID -> what it is (the IDs ``bench trust`` scores by).
CAUSES: dict[str, str] = {
    "image_size": "the intrinsics are not those of the detections' image (another resolution, a crop or a resize)",
    "box_coordinates": "box coordinates that are not pixels x1, y1, x2, y2 (normalised, x/y swapped, or x, y, w, h)",
    "hand_eye": "a hand-eye (camera-frame) error common to every view",
    "time_offset": "poses offset in time from the images (residuals follow the camera's motion)",
    "view_disagrees": "one view disagrees with the rest (another image's boxes, a wrong or swapped pose)",
    "duplicate_views": "views given more than once (same pose and boxes)",
    "pose_convention": "poses in another convention (world-to-camera, camera_link given as optical, facing away)",
    "distortion": "distortion coefficients in a wrong order or sign",
    "one_pose": "every view at the same pose (no baseline: depth is not observable)",
    "scatter": "boxes scattered beyond the sensor model (a noisier detector, or a mistake not named here)",
    "unexplained_boxes": "many boxes that no object explains",
}


@dataclass(frozen=True)
class Cause:
    """One named cause found in a session.

    Attributes
    ----------
    cause : str, an ID of :data:`CAUSES`
    message : str, one line: what was found, the evidence, what to check
    severity : str, ``suspect`` or ``unreliable`` (the verdict this cause alone gives)
    views : tuple of int, the views concerned (session order), empty: all or none in particular
    details : dict, the test's numbers (plain JSON values)
    """

    cause: str
    message: str
    severity: str = "suspect"
    views: tuple[int, ...] = ()
    details: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.cause not in CAUSES:
            raise ValueError(f"Cause.cause: unknown cause {self.cause!r}; expected one of {sorted(CAUSES)}")
        if self.severity not in VERDICTS[1:]:
            raise ValueError(f"Cause.severity: expected 'suspect' or 'unreliable', got {self.severity!r}")

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON values, as the result's ``quality.causes`` entries."""
        return {
            "cause": self.cause,
            "message": self.message,
            "severity": self.severity,
            "views": list(self.views),
            "details": dict(self.details),
        }


def verdict_of(causes: Iterable[Cause]) -> str:
    """The session verdict: the most severe of its causes' (``ok`` with none).

    >>> verdict_of([])
    'ok'
    >>> verdict_of([Cause("scatter", "boxes scattered", "suspect")])
    'suspect'
    """
    worst = 0
    for c in causes:
        worst = max(worst, VERDICTS.index(c.severity))
    return VERDICTS[worst]


def with_causes(quality: dict[str, Any], causes: Iterable[Cause]) -> dict[str, Any]:
    """A copy of a result's ``quality`` block with ``causes`` added (a cause ID and message given once) and the
    verdict recomputed from them all.

    >>> with_causes({}, [Cause("duplicate_views", "view 3 repeats view 1")])["verdict"]
    'suspect'
    """
    listed = [dict(c) for c in quality.get("causes", [])]
    seen = {(c.get("cause"), c.get("message")) for c in listed}
    for c in causes:
        if (c.cause, c.message) not in seen:
            listed.append(c.to_dict())
            seen.add((c.cause, c.message))
    worst = max((VERDICTS.index(str(c.get("severity", "suspect"))) for c in listed), default=0)
    worst = max(worst, VERDICTS.index(str(quality.get("verdict", "ok"))))
    return {**quality, "verdict": VERDICTS[worst], "causes": listed}
