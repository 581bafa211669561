"""Small built-in example data shipped with the package."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def example_session_path() -> Path:
    """Path of the built-in example session: one 30 mm sphere seen from three views."""
    return Path(str(resources.files("monovisual3d") / "data" / "single_sphere_session.json"))


def example_truth_path() -> Path:
    """Path of the ground truth that goes with :func:`example_session_path`."""
    return Path(str(resources.files("monovisual3d") / "data" / "single_sphere_truth.json"))
