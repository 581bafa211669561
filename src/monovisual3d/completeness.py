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
#: Boxes left over in a share at least this (and :data:`MIN_LEFT_OVER` or more) are reported whether or not two could be
#: one fruit: more than a detector's false positives and fruit seen once at the image's edge leave (a few per cent),
#: so the views disagree (another image's boxes, a wrong pose).
LEFT_OVER_SHARE = 0.10
MIN_LEFT_OVER = 3
#: Views listed by name in the unassociated-boxes line before "...".
MAX_VIEWS_LISTED = 6
#: Start of the line about an empty result, and the words of the line about unassociated boxes
#: (:func:`is_incomplete_reason` finds them in a batch's ``warnings`` column).
EMPTY_PREFIX = "no object found"
UNASSOCIATED_WORDS = "associated to no object"
#: What to try when nothing is found and the method said nothing more specific.
EMPTY_ADVICE = (
    "check that positions are metres, quaternions are (x, y, z, w) and pose_frame is right; "
    "try a wider --size-range, a lower --accept, or --method paper"
)
#: What to try about boxes no object explains, by method (the options that method takes), and for any other.
UNASSOCIATED_ADVICE = {
    "bayes": "add views of them, or try a lower --accept or a wider --size-range",
    "quadric": "add views of them (quadric fits objects with boxes in --min-views views, 3 or more; bayes from 2), "
    "or try a wider --size-range",
}
UNASSOCIATED_ADVICE_OTHER = "add views of them"


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
        - some boxes are associated to no object, and either two of them in different views could be one fruit
          (their centre rays meet as one fruit's would; else each is a fruit seen once or a false positive, and
          nothing more could be localised) or they are many (:data:`LEFT_OVER_SHARE`) (only for methods that report
          associations:
          an object's ``associations`` maps view index -> box index), unless the result's ``quality`` names causes
          (their messages say what to check); where ``quality`` lists its ``unexplained_boxes`` (a box no object holds
          but that lies at an object's predicted box within the session's noise is explained), only those.
    """
    with_boxes = [i for i, v in enumerate(session.views) if v.detections]
    if len(with_boxes) < MIN_VIEWS_WITH_BOXES:
        return []
    if not result.objects:
        if result.warnings:  # the method's own reason (it names the views with boxes)
            return [f"{EMPTY_PREFIX}: {result.warnings[0]}"]
        return [f"{EMPTY_PREFIX} although {len(with_boxes)} views have boxes: they agree on no object; {EMPTY_ADVICE}"]
    if not any(o.associations for o in result.objects):
        return []  # the method does not associate boxes: nothing to count
    if result.quality.get("causes"):
        return []  # the quality model named what is wrong (its messages are among the warnings): no generic line
    used = {(int(v), int(d)) for o in result.objects for v, d in o.associations.items()}
    if "unexplained_boxes" in result.quality:  # the quality model's: a free box beside its object, off by noise, is its
        unexplained = {(int(v), int(d)) for v, d in result.quality["unexplained_boxes"]}
        used = {(i, d) for i in with_boxes for d in range(len(session.views[i].detections))} - unexplained
    dropped = {i: [d for d in range(len(session.views[i].detections)) if (i, d) not in used] for i in with_boxes}
    dropped = {i: ds for i, ds in dropped.items() if ds}
    if not dropped:
        return []
    n_boxes = sum(len(session.views[i].detections) for i in with_boxes)
    n_dropped = sum(len(ds) for ds in dropped.values())
    many = n_dropped >= max(MIN_LEFT_OVER, LEFT_OVER_SHARE * n_boxes)
    if not many and not _could_be_missed(session, dropped):
        return []
    listed = "; ".join(
        f"view {i}: box{'es' if len(ds) > 1 else ''} {', '.join(map(str, ds))}"
        for i, ds in list(dropped.items())[:MAX_VIEWS_LISTED]
    )
    more = "; ..." if len(dropped) > MAX_VIEWS_LISTED else ""
    return [
        f"{n_dropped} of {n_boxes} boxes are {UNASSOCIATED_WORDS} ({listed}{more}): false positives, "
        f"or objects seen in too few views or scoring below the acceptance threshold; "
        f"{UNASSOCIATED_ADVICE.get(result.method, UNASSOCIATED_ADVICE_OTHER)}"
    ]


def _could_be_missed(session: Session, dropped: dict[int, list[int]]) -> bool:
    """Whether two boxes left over, from different views, could be one fruit (their centre rays meet as one fruit's
    would: :func:`~monovisual3d.session.rays.boxes_meet`). Where none can, each is a fruit seen in one view or a false
    positive: no method could localise more from these views, and the result is as complete as they allow."""
    import numpy as np

    from .session.rays import boxes_meet

    views = sorted(dropped)
    if len(views) < 2:
        return False
    T = np.stack([session.views[i].T_base_optical for i in views])
    boxes = [np.array([session.views[i].detections[d].bbox_xyxy for d in dropped[i]], dtype=float) for i in views]
    return boxes_meet(session.camera, T, boxes)


def strict_failure(reasons: list[str], result: Result) -> bool:
    """Whether ``--strict`` exits 1: a reason of :func:`incomplete_reasons`, or a quality verdict that is not ``ok``
    (:mod:`monovisual3d.verdict`).

    >>> strict_failure([], Result(objects=[], method="bayes", quality={"verdict": "suspect"}))
    True
    """
    return bool(reasons) or str(result.quality.get("verdict", "ok")) != "ok"


def merge_reasons(warnings: list[str], reasons: list[str]) -> list[str]:
    """``warnings`` with each reason in place of the warnings it quotes, the other reasons appended: one line per fact.

    Examples
    --------
    >>> merge_reasons(["too few views", "capped"], ["no object found: too few views", "boxes left"])
    ['no object found: too few views', 'capped', 'boxes left']
    """
    out = list(warnings)
    for reason in reasons:
        quoted = [i for i, w in enumerate(out) if w in reason]
        if not quoted:
            out.append(reason)
            continue
        out[quoted[0]] = reason
        for i in reversed(quoted[1:]):
            del out[i]
    return out


def is_incomplete_reason(line: str) -> bool:
    """Whether a warning line is one of :func:`incomplete_reasons` (e.g. read back from a batch's ``warnings`` column)."""
    return line.startswith(EMPTY_PREFIX) or UNASSOCIATED_WORDS in line
