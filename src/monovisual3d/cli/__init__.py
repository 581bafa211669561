"""Command-line interface: ``monovisual3d`` (alias ``mv3d``).

The CLI only parses arguments and calls the library. User errors end with
exit code 2 and a one-line message; warnings are printed as one line each.
"""

from __future__ import annotations

from . import (
    accuracy,  # noqa: F401
    active,  # noqa: F401
    batch,  # noqa: F401
    bench,  # noqa: F401
    core,  # noqa: F401  (registers commands)
    experiments,  # noqa: F401
    io,  # noqa: F401
    reference,  # noqa: F401
    ros2,  # noqa: F401
    sim,  # noqa: F401
    startup,  # noqa: F401
    view,  # noqa: F401
    warmup,  # noqa: F401
)
from ._app import app, main

__all__ = ["app", "main"]
