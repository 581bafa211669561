"""Options of the ``quadric`` method (:class:`QuadricConfig`); numpy-free at import, so the CLI starts fast."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from ...checks import is_real
from ...errors import InputError
from ...limits import DEFAULT_MAX_BYTES, DEFAULT_REACH_M
from ..options import check_shared_options

#: Where the box-to-object association comes from: the detections' track ids when present (``auto``),
#: always the track ids (``tracks``), or always the ``bayes`` method's association (``bayes``).
ASSOCIATIONS = ("auto", "tracks", "bayes")
#: Backends of the ``bayes`` association step (the quadric solve itself is a few small SVDs in numpy).
BACKENDS = ("numba", "numpy")
#: Fewest views that fix a dual quadric (LfD).
MIN_QUADRIC_VIEWS = 3


@dataclass(frozen=True)
class QuadricConfig:
    """Options of the ``quadric`` method (LfD's closed-form dual quadric, Rubino et al. TPAMI 2017).

    Attributes
    ----------
    association : str, where the box-to-object association comes from: auto (the detections' track ids
        when any detection has one, else the bayes method's), tracks, or bayes
    min_views : int, minimum number of views with an associated box (at least 3 for a dual quadric)
    size_range : tuple or str or None, metres, (min, max) semi-axis length, e.g. "0.01,0.12": passed to the
        bayes association step (see bayes)
    reach : float, metres, manipulator reach R of the bayes association step when the session has no workspace
    backend : str, numba or numpy: backend of the bayes association step
    threads : int or None, CPU threads of the bayes association step (None: chosen by the amount of work)
    max_memory : int or str, bytes (or text such as 2GiB): memory budget of the bayes association step
    """

    association: str = "auto"
    min_views: int = MIN_QUADRIC_VIEWS
    size_range: tuple[float, float] | str | None = None
    reach: float = DEFAULT_REACH_M
    backend: str = "numba"
    threads: int | None = None
    max_memory: int | str = DEFAULT_MAX_BYTES

    def __post_init__(self) -> None:
        if self.association not in ASSOCIATIONS:
            raise InputError(f"association: got {self.association!r}, expected one of {list(ASSOCIATIONS)}")
        v = self.min_views
        if not (is_real(v) and float(v).is_integer() and v >= MIN_QUADRIC_VIEWS):
            raise InputError(f"min_views: got {v!r}, expected an integer >= {MIN_QUADRIC_VIEWS} (a dual quadric needs 3 views)")
        object.__setattr__(self, "min_views", int(v))
        if self.backend not in BACKENDS:
            raise InputError(f"backend: got {self.backend!r}, expected one of {list(BACKENDS)} for method 'quadric'")
        check_shared_options(self)
        object.__setattr__(self, "size_range", self.bayes_config().size_range)  # size_range and reach are checked there

    def bayes_options(self) -> dict[str, Any]:
        """The options of the ``bayes`` run that gives the association when there are no track ids."""
        return {
            "size_range": self.size_range,
            "reach": self.reach,
            "backend": self.backend,
            "threads": self.threads,
            "max_memory": self.max_memory,
        }

    def bayes_config(self) -> Any:
        """The config of that ``bayes`` run, made through the methods registry (``quadric`` imports no other method)."""
        from .. import get_method

        return get_method("bayes").make_config(**self.bayes_options())

    def to_dict(self) -> dict[str, Any]:
        """The options as plain JSON values."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}
