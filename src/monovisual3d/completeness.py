"""Is a result complete? Say why not: empty although the views have boxes, or boxes left unassociated.

A result can be valid and still miss what the views show: no object at all
although two or more views have boxes, or (for methods that report which box
of each view an object explains, such as ``bayes``) boxes that no object
explains. :func:`incomplete_reasons` names each case in one line with its
reason and what to try; ``monovisual3d localize --strict`` exits 1 on any.

Examples
--------
>>> from monovisual3d.examples import example_session_path
>>> from monovisual3d import load_session, localize
>>> session = load_session(example_session_path())
>>> incomplete_reasons(session, localize(session))
[]
"""

from __future__ import annotations

from .result import Result
from .session import Session

#: Views with boxes needed before an empty result is worth a word (one view cannot localise anything).
MIN_VIEWS_WITH_BOXES = 2
#: Views listed by name in the unassociated-boxes line before "...".
MAX_VIEWS_LISTED = 6
#: What to try when nothing is found and the method said nothing more specific.
EMPTY_ADVICE = (
    "check that positions are metres, quaternions are (x, y, z, w) and pose_frame is right; "
    "try a wider --size-range, a lower --accept, or --method paper"
)


def incomplete_reasons(session: Session, result: Result) -> list[str]:
    """Lines saying why ``result`` may miss objects of ``session`` (empty list: nothing to say).

    Parameters
    ----------
    session : Session, the views the result came from
    result : Result, of any method

    Returns
    -------
    list of str, at most one line per case:
        - the result is empty although at least two views have boxes (with the method's own
          warning as the reason when it gave one, else what to try);
        - some boxes are associated to no object (only for methods that report associations:
          an object's ``associations`` maps view index -> box index).
    """
    with_boxes = [i for i, v in enumerate(session.views) if v.detections]
    if len(with_boxes) < MIN_VIEWS_WITH_BOXES:
        return []
    if not result.objects:
        if result.warnings:  # the method's own reason (it names the views with boxes)
            return [f"no object found: {result.warnings[0]}"]
        return [f"no object found although {len(with_boxes)} views have boxes: they agree on no object; {EMPTY_ADVICE}"]
    if not any(o.associations for o in result.objects):
        return []  # the method does not associate boxes: nothing to count
    used = {(int(v), int(d)) for o in result.objects for v, d in o.associations.items()}
    dropped = {i: [d for d in range(len(session.views[i].detections)) if (i, d) not in used] for i in with_boxes}
    dropped = {i: ds for i, ds in dropped.items() if ds}
    if not dropped:
        return []
    n_boxes = sum(len(session.views[i].detections) for i in with_boxes)
    n_dropped = sum(len(ds) for ds in dropped.values())
    listed = "; ".join(
        f"view {i}: box{'es' if len(ds) > 1 else ''} {', '.join(map(str, ds))}"
        for i, ds in list(dropped.items())[:MAX_VIEWS_LISTED]
    )
    more = "; ..." if len(dropped) > MAX_VIEWS_LISTED else ""
    return [
        f"{n_dropped} of {n_boxes} boxes are associated to no object ({listed}{more}): false positives, "
        f"or objects seen in too few views or scoring below the acceptance threshold; "
        "add views of them, or try a lower --accept or a wider --size-range"
    ]
