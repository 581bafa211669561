"""The one-call API: session in, objects out."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError
from .filter import HistogramFilter, PaperConfig
from .result import Result
from .session import Session, Workspace, load_session

#: Registered methods: name -> function(session, **options) -> Result.
METHODS: dict[str, Callable[..., Result]] = {}
DEFAULT_METHOD = "bayes"


def register_method(name: str) -> Callable[[Callable[..., Result]], Callable[..., Result]]:
    """Decorator that makes a localisation method available to :func:`localize` and the CLI."""

    def deco(fn: Callable[..., Result]) -> Callable[..., Result]:
        METHODS[name] = fn
        return fn

    return deco


def localize(
    session: Session | str | Path | dict[str, Any],
    *,
    method: str | None = None,
    workspace: Workspace | dict[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
    **options: Any,
) -> Result:
    """Localise the objects of a session.

    Parameters
    ----------
    session : Session, path or dict (validated with :func:`load_session`)
    method : str, one of ``METHODS`` (default ``DEFAULT_METHOD``)
    workspace : Workspace or {"min": [...], "max": [...]}, overrides the session's
    progress : callable(done, total), called after each view
    **options
        Method options. For ``paper``: ``kernel``, ``sigma_fraction``,
        ``resolution``, ``reach``, ``centre``, ``k``, ``keep_threshold``,
        ``weighted_kmeans``, ``max_bytes``, ``backend``, ``device``, ``refine_to``
        (see :class:`PaperConfig`).

    Returns
    -------
    Result

    Examples
    --------
    >>> from monovisual3d.examples import example_session_path
    >>> r = localize(example_session_path(), method="paper", resolution=0.01)
    >>> len(r.objects)
    1
    """
    session = load_session(session)
    if isinstance(workspace, dict):
        from .session import workspace_from_dict

        workspace = workspace_from_dict(workspace, "workspace")
    if workspace is not None:
        session = Session(session.camera, session.views, workspace, session.source)
    name = method or DEFAULT_METHOD
    if name not in METHODS:
        raise InputError(f"method: got {name!r}, expected one of {sorted(METHODS)}")
    return METHODS[name](session, progress=progress, **options)


@register_method("paper")
def localize_paper(session: Session, *, progress: Callable[[int, int], None] | None = None, **options: Any) -> Result:
    """The paper's histogram filter + k-means (see :class:`PaperConfig` for options)."""
    known = set(PaperConfig.__dataclass_fields__)
    unknown = sorted(set(options) - known)
    if unknown:
        raise InputError(f"{unknown[0]}: not an option of method 'paper', expected one of {sorted(known)}")
    config = PaperConfig(**options)
    if config.refine_to is not None:
        from .engine.sparse import localize_paper_sparse

        return localize_paper_sparse(session, config, progress=progress)
    t0 = time.perf_counter()
    filt = HistogramFilter(session.camera, config, workspace=session.workspace)
    for i, view in enumerate(session.views):
        filt.update(view)
        if progress is not None:
            progress(i + 1, len(session.views))
    t1 = time.perf_counter()
    objects = filt.estimate()
    t2 = time.perf_counter()
    if not filt.views_used:
        filt.messages.append("no view had a usable detection: nothing localised")
    grid = filt.grid.to_dict() if filt.grid is not None else {}
    return paper_result(objects, grid, config, (t0, t1, t2), list(filt.messages))


def paper_result(
    objects: list[Any], grid: dict[str, Any], config: PaperConfig, times: tuple[float, float, float], warnings: list[str]
) -> Result:
    """The paper method's :class:`Result` (dense and sparse paths): times are (start, filtered, estimated)."""
    t0, t1, t2 = times
    cfg = {k: (v if not isinstance(v, np.generic) else v.item()) for k, v in config.__dict__.items()}
    return Result(
        objects=objects,
        method="paper",
        grid=grid,
        timing_s={"filter": t1 - t0, "estimate": t2 - t1, "total": t2 - t0},
        config=cfg,
        warnings=warnings,
    )
