"""Options every method shares: memory budget, compute backend, threads.

Each method's config dataclass has the fields ``max_memory`` (default
:data:`~monovisual3d.limits.DEFAULT_MAX_BYTES`), ``backend`` and ``threads``, and
calls :func:`check_shared_options` in its ``__post_init__``, so
``localize(session, method=..., max_memory=..., backend=..., threads=...)`` means
the same for every method. ``backend`` names differ per method; each config checks
its own.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from ..checks import parse_bytes
from ..errors import InputError
from ..kernels.threads import check_threads

__all__ = ["check_shared_options", "nested_config", "option_names", "plain_options"]


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


def _nested_fields(cls: type) -> dict[str, type]:
    """The fields of the config dataclass ``cls`` that are option groups themselves (a dataclass built by default,
    e.g. ``BayesConfig.sensor``): field name -> its class."""
    out = {}
    for f in dataclasses.fields(cls):
        if f.default_factory is not dataclasses.MISSING and dataclasses.is_dataclass(made := f.default_factory()):
            out[f.name] = type(made)
    return out


def option_names(cls: type) -> dict[str, str]:
    """Every option of the config dataclass ``cls`` by name -> where it lives: ``""`` for a field of ``cls``, the
    group's field name for a field of a nested option group (``"sensor"`` for ``alpha``).

    Examples
    --------
    >>> from monovisual3d.methods.bayes.config import BayesConfig
    >>> names = option_names(BayesConfig)
    >>> names["accept"], names["alpha"], names["swap"]
    ('', 'sensor', 'tuning')
    """
    groups = _nested_fields(cls)
    out = {f.name: "" for f in dataclasses.fields(cls) if f.name not in groups}
    for group, sub in groups.items():
        out.update({f.name: group for f in dataclasses.fields(sub) if f.name not in out})
    return out


def nested_config(cls: type, options: dict[str, Any], method: str) -> Any:
    """The config ``cls(...)`` from options by name: a field of ``cls``, a field of one of its option groups by its
    own name (``alpha``) or dotted (``sensor.alpha``), or a whole group (``sensor={...}``); an unknown name is an
    error that names the known ones."""
    groups = _nested_fields(cls)
    where = option_names(cls)
    top: dict[str, Any] = {}
    inner: dict[str, dict[str, Any]] = {g: {} for g in groups}
    for key, value in options.items():
        group, _, leaf = key.rpartition(".")
        if group in groups and leaf in {n for n, g in where.items() if g == group}:
            inner[group][leaf] = value
        elif not group and key in groups and isinstance(value, dict):
            inner[key].update(value)
        elif not group and key in where:
            (inner[where[key]] if where[key] else top)[key] = value
        else:
            raise InputError(f"{key}: not an option of method {method!r}, expected one of {sorted(where)}")
    for group, values in inner.items():
        if values or group in top:
            base = top.get(group, groups[group]())
            if not isinstance(base, groups[group]):
                raise InputError(f"{group}: got {type(base).__name__}, expected a {groups[group].__name__}")
            top[group] = dataclasses.replace(base, **values) if values else base
    return cls(**top)


def plain_options(config: Any) -> dict[str, Any]:
    """A config's options as plain JSON values: tuples as lists, option groups as nested objects."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        v = getattr(config, f.name)
        out[f.name] = plain_options(v) if dataclasses.is_dataclass(v) else list(v) if isinstance(v, tuple) else v
    return out
