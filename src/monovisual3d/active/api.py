"""One call from a session file to a next-view plan: what ``monovisual3d next-view`` runs.

:func:`plan_session` validates the candidates and ``count`` (before the localisation, which
takes the time), localises the session's views, builds the ``cap:`` candidates when asked,
plans and returns the JSON-ready plan. Errors are :class:`~monovisual3d.errors.InputError`
whose message starts with the parameter's name (``count: ...``, ``reach_m: ...``,
``base: ...``, ``target: ...``) or with the file at fault.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import is_int
from ..errors import InputError
from ..frames import T_cameralink_optical, check_transform, transform_from_position_quaternion
from ..io.poses import T_base_ee_from_T_base_camera
from ..result import Result
from ..session import Session, Workspace
from .candidates import CapSpec, cap_poses, load_candidates, pose_to_dict
from .config import PlannerConfig
from .planner import load_planning_session, plan_from_state
from .targets import PlannerState, default_workspace

#: A point given as ``"X,Y,Z"`` (metres) or as three numbers.
Point = str | Sequence[float]
#: Half side of the workspace cube around ``target`` when the session has none, metres (a 0.4 m cube).
TARGET_HALF_SIDE_M = 0.2


def parse_point(value: Point, name: str) -> tuple[float, float, float]:
    """A point in metres from ``"X,Y,Z"`` or three numbers; InputError ``NAME: got ..., expected X,Y,Z in metres``."""
    try:
        v = tuple(float(x) for x in (value.split(",") if isinstance(value, str) else value))
    except (ValueError, TypeError):
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise InputError(f"{name}: got {value!r}, expected X,Y,Z in metres")
    return v  # type: ignore[return-value]


def plan_session(
    session: str | Path,
    candidates: str,
    *,
    count: int = 1,
    target_mm: float = 5.0,
    motion_weight: float = 0.0,
    reach_m: float | None = None,
    base: Point = (0.0, 0.0, 0.0),
    target: Point | None = None,
    box_noise: float | str | None = "auto",
    tool_frame: str | None = None,
    T_tool_camera: ArrayLike | None = None,
) -> dict[str, Any]:
    """Choose the next camera pose(s) for the views in a session file; report "done" when good enough.

    One unit of thought: the documented options make most of its length; the body checks them all before the
    localisation (which takes the time), then plans.

    Parameters
    ----------
    session : path of a session file (JSON/YAML); it may have no views yet
    candidates : str, a candidate file ``{"poses": [...]}`` in the session's ``pose_frame``, or a
        ``cap:N[...]`` spec (:class:`~monovisual3d.active.candidates.CapSpec`)
    count : int, views to choose jointly (batch)
    target_mm : float, stopping rule: largest 95 % semi-axis of every object, mm
    motion_weight : float, gain (mm) lost per metre of camera travel
    reach_m : float, arm reach in metres around ``base`` (default: the cap's ``reach``, else none)
    base : centre of the reach sphere, metres, base frame
    target : cap centre, metres; default the workspace centre, else the estimates' mean, else
        0.5 m along the first view. Also the workspace (a 0.4 m cube) when the session has none.
    box_noise : float, detector box noise as a fraction of the box size; ``"auto"`` (default): estimated
        from the boxes seen so far; None: the sensor model's 5 %
    tool_frame : str, optional, name of the arm's tool frame: ``pose`` (and ``poses``) become the tool's goal
        poses ``T_base_tool = T_base_camera @ inv(T_tool_camera)``, the camera's are kept as ``camera_pose``
        (``camera_poses``); give it with ``T_tool_camera``
    T_tool_camera : array_like, shape (4, 4), optional, the hand-eye calibration: the camera (in the session's
        ``pose_frame`` convention) in the tool frame, metres

    Returns
    -------
    dict
        :meth:`~monovisual3d.active.planner.Plan.to_dict` plus ``n_objects``, ``views``, ``warnings`` and ``quality``
        (the localisation's, as ``localize`` gives them) and, for ``cap:``, ``candidates`` (the poses the indices
        refer to, after the reach filter).
    """
    if not is_int(count) or count < 1:
        raise InputError(f"count: got {count}, expected a positive integer")
    T_tool_camera = _check_tool(tool_frame, T_tool_camera)
    pose_frame = _pose_frame(session)
    sess = load_planning_session(session)
    base_c = parse_point(base, "base")
    # validate the candidates (and count) before the localisation, which takes the time
    spec, cands = _parse_candidates(candidates, pose_frame, count)
    # every planner option is checked here too, before the localisation
    cfg = PlannerConfig(target_mm=target_mm, motion_weight=motion_weight, base_centre=base_c, box_noise=box_noise)
    result = _localise(sess)
    objects = [] if result is None else list(result.objects)
    state = PlannerState(sess.camera, sess.views, tuple(objects), sess.workspace)
    if spec is not None:
        cands = _cap_candidates(spec, state, session, target, base_c)
    assert cands is not None
    _check_count(count, len(cands))
    cfg = replace(cfg, reach_m=_reach_m(reach_m, spec))
    state = _with_target_workspace(state, target)
    out = plan_from_state(state, cands, count=count, config=cfg).to_dict(pose_frame)
    out["n_objects"] = len(objects)
    out["views"] = len(sess.views)
    out["warnings"] = [] if result is None else list(result.warnings)  # as localize says them
    out["quality"] = {} if result is None else dict(result.quality)
    if spec is not None:
        out["candidates"] = [pose_to_dict(T, pose_frame) for T in cands]
    if tool_frame is not None and T_tool_camera is not None:
        _tool_poses(out, tool_frame, T_tool_camera, pose_frame)
    return out


def _check_tool(tool_frame: str | None, T_tool_camera: ArrayLike | None) -> NDArray[np.float64] | None:
    """The hand-eye transform, checked; InputError ``tool_frame: ...`` when only one of the two is given."""
    if (tool_frame is None) != (T_tool_camera is None):
        raise InputError(
            "tool_frame: give the tool frame's name together with the hand-eye calibration T_tool_camera "
            "(the camera in the tool frame), or neither"
        )
    if T_tool_camera is None:
        return None
    if not str(tool_frame).strip():
        raise InputError(f"tool_frame: got {tool_frame!r}, expected the name of the tool frame")
    return check_transform(np.asarray(T_tool_camera, dtype=float), where="T_tool_camera")


def _tool_poses(out: dict[str, Any], tool_frame: str, T_tool_camera: NDArray[np.float64], pose_frame: str) -> None:
    """Turn the plan's ``pose``/``poses`` into the tool's goal poses; keep the camera's as ``camera_pose``/``camera_poses``."""
    T_tool_optical = T_tool_camera @ T_cameralink_optical() if pose_frame == "camera_link" else T_tool_camera

    def tool(pose: dict[str, Any]) -> dict[str, Any]:
        T_base_optical = transform_from_position_quaternion(pose["position"], pose["quaternion_xyzw"])
        if pose_frame == "camera_link":
            T_base_optical = T_base_optical @ T_cameralink_optical()
        return pose_to_dict(T_base_ee_from_T_base_camera(T_base_optical, T_tool_optical), "optical")

    out["camera_pose"], out["pose"] = out["pose"], tool(out["pose"])
    if "poses" in out:
        out["camera_poses"], out["poses"] = out["poses"], [tool(p) for p in out["poses"]]
    out["tool_frame"] = tool_frame


def _parse_candidates(candidates: str, pose_frame: str, count: int) -> tuple[CapSpec | None, NDArray[np.float64] | None]:
    """The ``cap:`` spec (its poses come after the localisation) or the poses of the candidate file; checks ``count``.

    Returns
    -------
    spec : CapSpec or None (a candidate file)
    poses : ndarray, shape (N, 4, 4), ``T_base_optical`` of the file's candidates, or None (a ``cap:`` spec)
    """
    if candidates.strip().startswith("cap:"):
        spec = CapSpec.parse(candidates)
        _check_count(count, spec.n)
        return spec, None
    if not Path(candidates).exists():  # neither a spec nor a file: say both forms
        raise InputError(f"candidates: {candidates!r}: file not found, expected a poses file or cap:N (e.g. cap:60)")
    cands = load_candidates(candidates, pose_frame)
    _check_count(count, len(cands))
    return None, cands


def _check_count(count: int, n_candidates: int) -> None:
    """InputError ``count: ...`` when more views are asked for than there are candidates."""
    if count > n_candidates:
        raise InputError(f"count: got {count}, expected at most {n_candidates} (the number of candidates)")


def _reach_m(reach_m: float | None, spec: CapSpec | None) -> float:
    """The arm reach in metres: ``reach_m``, else the cap's ``reach``, else none (inf); InputError ``reach_m: ...``."""
    if reach_m is None and spec is not None and math.isfinite(spec.reach_m):
        reach_m = spec.reach_m
    if reach_m is None:
        return math.inf
    if not (reach_m > 0 and math.isfinite(reach_m)):
        raise InputError(f"reach_m: got {reach_m}, expected a positive number of metres")
    return reach_m


def _with_target_workspace(state: PlannerState, target: Point | None) -> PlannerState:
    """``state`` with a cube of half side :data:`TARGET_HALF_SIDE_M` around ``target`` as workspace, if it has none."""
    if target is None or state.workspace is not None:
        return state
    c = np.array(parse_point(target, "target"))
    return replace(state, workspace=Workspace(c - TARGET_HALF_SIDE_M, c + TARGET_HALF_SIDE_M))


def _pose_frame(session: str | Path) -> str:
    from .._structured import read_structured_file

    raw = read_structured_file(session)
    return raw.get("pose_frame", "optical") if isinstance(raw, dict) else "optical"


def _localise(sess: Session) -> Result | None:
    """The session's result (its warnings kept in it, not raised), or None before two views with detections."""
    from ..api import localize

    if sum(1 for v in sess.views if v.detections) < 2:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return localize(sess)


def _cap_candidates(
    spec: CapSpec, state: PlannerState, session: str | Path, target: Point | None, base_c: tuple[float, float, float]
) -> NDArray[np.float64]:
    """The cap's poses around ``target`` (default: the workspace's centre), axis along the first view."""
    if target is not None:
        centre = np.array(parse_point(target, "target"))
    else:
        try:
            ws = default_workspace(state)
        except InputError:
            raise InputError(f"{session}: no views and no workspace; give target X,Y,Z for the cap") from None
        centre = 0.5 * (ws.min + ws.max)
    axis = state.views[0].T_base_optical[:3, 3] if state.views else None
    return cap_poses(spec, centre, axis=axis, base_centre=base_c)
