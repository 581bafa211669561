"""The localisation methods and their explicit registry.

Each method is a config dataclass (every option a field, documented in its
docstring's Attributes section) and a ``run(session, config, progress=None) ->
Result`` function. :data:`METHODS` maps the method's name to both; the CLI
builds its options from the config classes, and :func:`monovisual3d.localize`
looks methods up here. The run functions are imported on first use, so
listing the methods stays cheap.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import InputError

if TYPE_CHECKING:  # numpy-level modules: keep listing the methods (the CLI's --help) light
    from ..result import Result
    from ..session import Session

#: The method used when none is named.
DEFAULT_METHOD = "bayes"


@dataclass(frozen=True)
class Method:
    """A registered method: its name, a one-line summary, and where its config class and run function live.

    Attributes
    ----------
    name : str
    summary : str
    config_path : str, ``"module:ClassName"`` of the config dataclass
    run_path : str, ``"module:function"`` of ``run(session, config, *, progress=None) -> Result``
    """

    name: str
    summary: str
    config_path: str
    run_path: str

    @property
    def config_class(self) -> type:
        return _load(self.config_path)

    @property
    def run(self) -> Callable[..., Result]:
        return _load(self.run_path)

    def make_config(self, **options: Any) -> Any:
        """The method's config from keyword options by name (those of its option groups too, e.g. ``alpha`` of
        ``BayesConfig.sensor``); an unknown option is an error naming the known ones."""
        from .options import nested_config

        return nested_config(self.config_class, options, self.name)


def _load(path: str) -> Any:
    module, name = path.split(":")
    return getattr(importlib.import_module(module), name)


#: name -> :class:`Method`. Add a method by adding an entry here (see ``CONTRIBUTING.md``).
METHODS: dict[str, Method] = {
    "bayes": Method(
        "bayes",
        "size-aware, ghost-free: box likelihood, explaining-away extraction, continuous refinement (default)",
        "monovisual3d.methods.bayes.config:BayesConfig",
        "monovisual3d.methods.bayes.localizer:run",
    ),
    "paper": Method(
        "paper",
        "MonoVisual3DFilter as published: histogram filter over a voxel grid, square/Gaussian kernel, k-means",
        "monovisual3d.methods.paper.config:PaperConfig",
        "monovisual3d.methods.paper.run:run",
    ),
    "quadric": Method(
        "quadric",
        "LfD's closed-form dual quadric (Rubino et al. 2017): ellipses in the boxes, >= 3 views, given association "
        "(track ids) or that of bayes",
        "monovisual3d.methods.quadric.config:QuadricConfig",
        "monovisual3d.methods.quadric.localizer:run",
    ),
}


def register_method(name: str, summary: str, config_path: str, run_path: str) -> Method:
    """Add a method to :data:`METHODS`, as an entry in the dict does, for a method whose code lives outside this package.

    Register before the CLI is built (before ``monovisual3d.cli`` is imported): ``localize``'s options are
    generated from the registered configs. Paths are ``"module:name"``; nothing is imported until the method is used.

    Examples
    --------
    >>> paper = METHODS["paper"]
    >>> copy = register_method("paper-copy", "the paper's method again", paper.config_path, paper.run_path)
    >>> copy.config_class is paper.config_class
    True
    >>> del METHODS["paper-copy"]
    """
    if not (isinstance(name, str) and re.fullmatch(r"[a-z][a-z0-9+_-]*", name)):
        raise InputError(f"method name: got {name!r}, expected lower-case letters, digits, '-', '_' or '+'")
    if name in METHODS:
        raise InputError(f"method name: {name!r} is already registered")
    for field, path in (("config_path", config_path), ("run_path", run_path)):
        if not (isinstance(path, str) and re.fullmatch(r"[\w.]+:\w+", path)):
            raise InputError(f"{field}: got {path!r}, expected 'module:name'")
    METHODS[name] = Method(name, summary, config_path, run_path)
    return METHODS[name]


def get_method(name: str | None) -> Method:
    """The registered method called ``name`` (``None``: :data:`DEFAULT_METHOD`)."""
    name = DEFAULT_METHOD if name is None else name
    if not isinstance(name, str) or name not in METHODS:
        raise InputError(f"method: got {name!r}, expected one of {sorted(METHODS)}")
    return METHODS[name]


def run_method(
    session: Session,
    name: str | None = None,
    config: Any = None,
    progress: Callable[[int, int], None] | None = None,
    **options: Any,
) -> Result:
    """Run a method on a loaded session, with a ready config or keyword options (not both)."""
    method = get_method(name)
    if config is not None:
        if options:
            raise InputError(f"{sorted(options)[0]}: give the options in the config or as keywords, not both")
        if not isinstance(config, method.config_class):
            raise InputError(
                f"config: got {type(config).__name__}, expected {method.config_class.__name__} for method {method.name!r}"
            )
    else:
        config = method.make_config(**options)
    from ..kernels.threads import thread_limit

    with thread_limit(config.threads):
        return method.run(session, config, progress=progress)
