"""The node's next view: :func:`monovisual3d.active.plan_next_view` on the live estimate, as a camera or tool pose.

Candidates are a poses file (fixed) or a ``cap:N[...]`` spec, whose poses are laid out afresh at each plan
around the workspace's centre (else the estimates' mean), facing the first view, as ``monovisual3d next-view``
does. With a tool frame the chosen camera pose becomes the tool's goal pose through the hand-eye transform
``T_tool_camera``: ``T_base_tool = T_base_camera @ inv(T_tool_camera)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..active.candidates import CapSpec, cap_poses, load_candidates
from ..active.planner import Plan, plan_next_view
from ..io.poses import T_base_ee_from_T_base_camera
from ..result import DetectedObject
from ..session import Workspace


@dataclass(frozen=True)
class NextView:
    """A plan's first pick.

    Attributes
    ----------
    T_base_camera : ndarray, shape (4, 4), the chosen camera pose (optical frame)
    T_base_tool : ndarray, shape (4, 4) or None, the tool's goal pose (with a hand-eye transform)
    gain : float, expected gain, mm
    done : bool, the stopping rule says the estimate is good enough
    index : int, the chosen candidate
    """

    T_base_camera: NDArray[np.float64]
    T_base_tool: NDArray[np.float64] | None
    gain: float
    done: bool
    index: int


class NextViewPlanner:
    """Plans the next view from a candidates file or ``cap:`` spec (checked at construction).

    Parameters
    ----------
    candidates : str, a poses file (optical frame unless the file says ``pose_frame``) or ``cap:N[...]``
    target_mm : float, the stopping rule (largest 95 % semi-axis of every fruit, mm)
    workspace : Workspace or None, the region searched; its centre is the cap's target
    """

    def __init__(self, candidates: str, target_mm: float = 5.0, workspace: Workspace | None = None) -> None:
        self.spec: CapSpec | None = None
        self.poses: NDArray[np.float64] | None = None
        if candidates.strip().startswith("cap:"):
            self.spec = CapSpec.parse(candidates)
        else:
            self.poses = load_candidates(candidates, "optical")
        self.target_mm = target_mm
        self.workspace = workspace

    def _candidates(
        self, first_view_position: NDArray[np.float64], objects: Sequence[DetectedObject]
    ) -> NDArray[np.float64] | None:
        if self.poses is not None:
            return self.poses
        assert self.spec is not None
        if self.workspace is not None:
            centre = 0.5 * (self.workspace.min + self.workspace.max)
        elif objects:
            centre = np.mean([o.position for o in objects], axis=0)
        else:
            return None
        return cap_poses(self.spec, centre, axis=first_view_position)

    def plan(
        self, localizer: Any, objects: Sequence[DetectedObject], T_tool_camera: NDArray[np.float64] | None
    ) -> NextView | None:
        """The next view for the localizer's views and current ``objects``; None before the cap has a centre."""
        if not localizer.views:
            return None
        candidates = self._candidates(localizer.views[0].T_base_optical[:3, 3], objects)
        if candidates is None:
            return None
        reach = self.spec.reach_m if self.spec is not None and math.isfinite(self.spec.reach_m) else math.inf
        plan: Plan = plan_next_view(localizer, candidates, objects=list(objects), target_mm=self.target_mm, reach_m=reach)
        T_cam = plan.poses[0]
        T_tool = None if T_tool_camera is None else T_base_ee_from_T_base_camera(T_cam, T_tool_camera)
        return NextView(T_cam, T_tool, float(plan.gain), bool(plan.done), int(plan.index))


__all__ = ["NextView", "NextViewPlanner"]
