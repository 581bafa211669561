"""Options every method shares: memory budget, compute backend, threads.

Each method's config dataclass has the fields ``max_memory`` (default
:data:`~monovisual3d.limits.DEFAULT_MAX_BYTES`), ``backend`` and ``threads``, and
calls :func:`check_shared_options` in its ``__post_init__``, so
``localize(session, method=..., max_memory=..., backend=..., threads=...)`` means
the same for every method. ``backend`` names differ per method; each config checks
its own.
"""

from __future__ import annotations

from typing import Any

from ..checks import parse_bytes
from ..kernels.threads import check_threads

__all__ = ["check_shared_options"]


def check_shared_options(config: Any) -> None:
    """Validate and normalise ``config.max_memory`` (bytes, int) and ``config.threads`` of a frozen config dataclass.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Toy:
    ...     max_memory: int | str = "1GiB"
    ...     threads: int | None = None
    ...     def __post_init__(self) -> None:
    ...         check_shared_options(self)
    >>> Toy().max_memory
    1073741824
    """
    object.__setattr__(config, "max_memory", parse_bytes(config.max_memory))
    object.__setattr__(config, "threads", check_threads(config.threads))
