"""The one-call API: session in, objects out."""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .errors import InputError, InputWarning, prefixed
from .methods import DEFAULT_METHOD, METHODS, get_method, run_method
from .result import Result
from .session import Session, Workspace
from .session.diagnose import check_session, views_as_given
from .session.load import load_session
from .verdict import Cause, with_causes

__all__ = ["DEFAULT_METHOD", "METHODS", "localize", "warmup"]

#: The methods with compiled kernels, those :func:`warmup` prepares by default.
COMPILED_METHODS = ("bayes", "paper")


def localize(
    session: Session | str | Path | dict[str, Any],
    *,
    method: str | None = None,
    config: Any = None,
    workspace: Workspace | dict[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
    **options: Any,
) -> Result:
    """Localise the objects of a session.

    Parameters
    ----------
    session : Session, path or dict (validated with :func:`load_session`)
    method : str, one of ``METHODS`` (default ``DEFAULT_METHOD``; with ``config``, the method of that config)
    config : a method's config dataclass (:class:`~monovisual3d.methods.bayes.BayesConfig`,
        :class:`~monovisual3d.PaperConfig`) instead of keyword options
    workspace : Workspace or {"min": [...], "max": [...]}, overrides the session's
    progress : callable(done, total), called after each view
    **options
        Fields of the method's config (``monovisual3d options METHOD`` lists them), e.g. ``resolution``,
        ``max_memory``, ``backend``, ``threads``; ``kernel``, ``k``, ``centre`` for ``paper``; ``accept``,
        ``pose_sigma_mm`` for ``bayes``.

    Returns
    -------
    Result

    Notes
    -----
    Before the method runs, :func:`~monovisual3d.session.diagnose.check_session` tests the input itself (box
    coordinates against the image, pose conventions, duplicated views, one pose, distortion coefficients). Each cause
    found is raised as an :class:`~monovisual3d.errors.InputWarning`, listed in ``result.warnings`` and merged into
    ``result.quality``; views given twice are counted once (``associations`` still index the views as given).

    Examples
    --------
    >>> from monovisual3d.examples import example_session_path
    >>> r = localize(example_session_path(), method="paper", resolution=0.01)
    >>> len(r.objects)
    1
    """
    session = load_session(session)
    if isinstance(workspace, dict):
        from .session.load import workspace_from_dict

        workspace = workspace_from_dict(workspace, "workspace")
    if workspace is not None:
        session = dataclasses.replace(session, workspace=workspace)
    if config is not None and method is None:
        matches = [m.name for m in METHODS.values() if isinstance(config, m.config_class)]
        if not matches:
            raise InputError(f"config: got {type(config).__name__}, expected the config class of one of {sorted(METHODS)}")
        method = matches[0]
    get_method(method)  # a bad name fails before anything runs
    start = time.perf_counter()
    checked, causes, messages = _checked(session)
    result = run_method(checked, method, config, progress, **options)
    result.timing_s.setdefault("total", time.perf_counter() - start)  # a method that does not time itself
    return _with_input_causes(result, causes, messages)


def _checked(session: Session) -> tuple[Session, list[Cause], list[str]]:
    """The input checks on ``session``: the session to run (duplicates dropped), the causes, and their messages (each
    also raised as an InputWarning)."""
    checked, causes = check_session(session)
    messages = [prefixed(session.source, c.message) for c in causes]
    for message in messages:
        warnings.warn(InputWarning(message), stacklevel=3)
    return checked, causes, messages


def _with_input_causes(result: Result, causes: list[Cause], messages: list[str]) -> Result:
    """``result`` with the input checks' causes: their messages first in its warnings, merged into its quality, and
    its objects' associations indexing the views as given (duplicates included)."""
    if causes:
        for obj in result.objects:
            obj.associations = views_as_given(obj.associations, causes)
        result.warnings[:0] = [m for m in messages if m not in result.warnings]
        result.quality = with_causes(result.quality, causes)
    return result


def warmup(methods: Sequence[str] | None = None) -> dict[str, float]:
    """Compile every compiled kernel of ``methods`` ahead of time (or load it, when already compiled): one
    localisation of the built-in example session per method.

    A fresh installation compiles its kernels on their first call (seconds to tens of seconds) and caches them on
    disk; call this where that first call must not wait: a robot before its first view, a Docker image build
    (``monovisual3d warmup`` on the command line). It also writes the package's Python bytecode where it is missing
    (:func:`write_bytecode`).

    Parameters
    ----------
    methods : names of :data:`METHODS`, default :data:`COMPILED_METHODS`

    Returns
    -------
    dict, method -> seconds taken

    Examples
    --------
    >>> seconds = warmup(["bayes"])
    >>> sorted(seconds)
    ['bayes']
    """
    from .examples import example_session_path

    write_bytecode()
    out = {}
    session = load_session(example_session_path())
    for method in COMPILED_METHODS if methods is None else methods:
        get_method(method)
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            localize(session, method=method)
        out[method] = time.perf_counter() - start
    return out


def write_bytecode() -> bool:
    """Write the package's missing bytecode (``__pycache__/*.pyc``) where Python did not: with
    ``PYTHONDONTWRITEBYTECODE`` set (usual in Docker images) and an editable install, every process compiles the
    package's modules from source again (0.17 s of a warm ``localize``; the command line also writes the bytecode of
    the modules each command imported, :func:`.kernels.bytecode.cache_imported_bytecode`). Python reads bytecode whatever that
    setting says. Whether every module's bytecode is in place (False where the package's folder is read-only).

    Examples
    --------
    >>> write_bytecode() in (True, False)
    True
    """
    from .kernels.bytecode import compile_sources, package_sources, stale_sources

    stale = stale_sources(package_sources())
    return compile_sources(stale) == len(stale)
