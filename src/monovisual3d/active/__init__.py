"""Active perception: choose the next camera pose (next-best-view) and know when to stop.

- :mod:`~monovisual3d.active.candidates`: candidate poses from a file or on a spherical cap;
- :mod:`~monovisual3d.active.planner`: :func:`plan_next_view` ranks candidates by expected gain
  (information, visibility, discovery, motion) and applies the stopping rule; its parts:
  :mod:`~monovisual3d.active.config` (:class:`PlannerConfig`), :mod:`~monovisual3d.active.information`
  (box Jacobians, Fisher information, occlusion) and :mod:`~monovisual3d.active.targets` (objects and
  tentative objects with their information so far);
- :mod:`~monovisual3d.active.api`: :func:`plan_session`, a session file to a JSON-ready plan (``next-view``);
- :mod:`~monovisual3d.active.loop`: the closed loop in simulation (plan, render, detect, update)
  and the baselines the benchmark compares with.
"""

from __future__ import annotations

from .api import plan_session
from .candidates import CapSpec, cap_poses, check_candidates, load_candidates
from .config import PlannerConfig
from .information import ellipsoid95_mm
from .planner import Plan, plan_from_state, plan_next_view
from .targets import PlannerState

__all__ = [
    "CapSpec",
    "Plan",
    "PlannerConfig",
    "PlannerState",
    "cap_poses",
    "check_candidates",
    "ellipsoid95_mm",
    "load_candidates",
    "plan_from_state",
    "plan_next_view",
    "plan_session",
]
