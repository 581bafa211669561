"""``ros2 node`` (the live node over DDS) and ``ros2 play`` (a session published as a robot would)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ._app import app, console, handle_errors, plain
from .io import LabelOption, MinScoreOption, WorkspaceOption, workspace_option
from .options import method_config, with_method_options

ros2_app = typer.Typer(
    help="Live on a ROS 2 robot over DDS, no ROS installation needed (extra [ros2]): the node, and a session player.",
    no_args_is_help=True,
    rich_markup_mode=None,
)
app.add_typer(ros2_app, name="ros2")

_TOPIC_HELP = "Topic of the {what} [default: {default}]."


def _topic(flag: str, what: str, default: str) -> Any:
    return typer.Option(flag, help=_TOPIC_HELP.format(what=what, default=default), show_default=False)


CameraInfoTopic = Annotated[str | None, _topic("--camera-info", "sensor_msgs/CameraInfo (in)", "/camera/camera_info")]
DetectionsTopic = Annotated[str | None, _topic("--detections", "vision_msgs/Detection2DArray (in)", "/detections")]
TfTopic = Annotated[str | None, _topic("--tf", "moving transforms (in)", "/tf")]
TfStaticTopic = Annotated[str | None, _topic("--tf-static", "static transforms (in)", "/tf_static")]
BaseFrame = Annotated[str, typer.Option("--base-frame", help="The robot's base frame in TF.")]

#: Fields of NodeConfig and PlayConfig named in their errors, and the flags they come from.
_FLAGS = {
    "base_frame": "--base-frame",
    "camera_frame": "--camera-frame",
    "tool_frame": "--tool-frame",
    "pose_frame": "--pose-frame",
    "tf_timeout_s": "--tf-timeout",
    "max_gap_s": "--max-gap",
    "min_score": "--min-score",
    "target_mm": "--target-mm",
    "rate_hz": "--rate",
    "tf_period_s": "--tf-period",
    "tf_delay_s": "--tf-delay",
    "wait_s": "--wait",
    "camera_info": "--camera-info",
    "detections": "--detections",
    "tf": "--tf",
    "tf_static": "--tf-static",
    "reset": "--reset",
    "out_detections": "--out-detections",
    "out_markers": "--out-markers",
    "out_status": "--out-status",
    "out_next_view": "--out-next-view",
}


@contextlib.contextmanager
def _as_flags() -> Iterator[None]:
    """Library errors that start with a config field's name, in CLI words (``tf_timeout_s: ...`` -> ``--tf-timeout: ...``)."""
    try:
        yield
    except InputError as exc:
        name, sep, rest = str(exc).partition(":")
        if sep and name in _FLAGS:
            raise InputError(_FLAGS[name] + sep + rest) from None
        raise


def _opt(flag: str, help: str) -> Any:
    return typer.Option(flag, help=help)


PrefixOption = Annotated[str, _opt("--prefix", "Prefix of the node's own topics (outputs and reset).")]
ResetTopic = Annotated[str | None, _topic("--reset", "std_msgs/Empty that starts a new session (in)", "PREFIX/reset")]
OutDetections = Annotated[str | None, _topic("--out-detections", "vision_msgs/Detection3DArray (out)", "PREFIX/detections")]
OutMarkers = Annotated[str | None, _topic("--out-markers", "visualization_msgs/MarkerArray (out)", "PREFIX/markers")]
OutStatus = Annotated[str | None, _topic("--out-status", "std_msgs/String JSON status (out)", "PREFIX/status")]
OutNextView = Annotated[str | None, _topic("--out-next-view", "geometry_msgs/PoseStamped (out)", "PREFIX/next_view")]
NodeCameraFrame = Annotated[
    str | None,
    typer.Option(
        "--camera-frame", help="The camera's TF frame [default: each Detection2DArray's header.frame_id].", show_default=False
    ),
]
PoseFrameOption = Annotated[
    str, _opt("--pose-frame", "Convention of the camera frame: optical (REP 103 *_optical_frame) or camera_link.")
]
NodeToolFrame = Annotated[
    str | None, _opt("--tool-frame", "Publish the next view as this frame's goal pose (via the static TF to the camera).")
]
TfTimeout = Annotated[float, _opt("--tf-timeout", "Seconds a view waits for TF (and a first CameraInfo) arriving after it.")]
MaxGap = Annotated[float, _opt("--max-gap", "Largest time (s) between a view and the TF samples used for it.")]
CalibrationOption = Annotated[Path | None, _opt("--camera", "Calibration file to use instead of the CameraInfo topic.")]
CandidatesOption = Annotated[
    str | None, _opt("--candidates", "Next-view candidates: a poses file or cap:N[...] (as next-view); publishes next_view.")
]
TargetMm = Annotated[float, _opt("--target-mm", "Next view's stopping rule: largest 95 % semi-axis of every fruit, mm.")]
WarmupOption = Annotated[
    bool, _opt("--warmup/--no-warmup", "Compile the kernels at start with one estimate of the built-in example.")
]
ReliableInputs = Annotated[
    bool,
    _opt("--reliable-inputs", "Subscribe to detections and camera info reliably (default best effort: matches every publisher)."),
]


@ros2_app.command("node")
@handle_errors
@with_method_options(methods=("bayes",))
def node_cmd(
    camera_info: CameraInfoTopic = None,
    detections: DetectionsTopic = None,
    tf: TfTopic = None,
    tf_static: TfStaticTopic = None,
    prefix: PrefixOption = "/fruit",
    reset: ResetTopic = None,
    out_detections: OutDetections = None,
    out_markers: OutMarkers = None,
    out_status: OutStatus = None,
    out_next_view: OutNextView = None,
    base_frame: BaseFrame = "base_link",
    camera_frame: NodeCameraFrame = None,
    pose_frame: PoseFrameOption = "optical",
    tool_frame: NodeToolFrame = None,
    tf_timeout: TfTimeout = 1.0,
    max_gap: MaxGap = 0.1,
    camera: CalibrationOption = None,
    workspace: WorkspaceOption = None,
    label: LabelOption = None,
    min_score: MinScoreOption = None,
    candidates: CandidatesOption = None,
    target_mm: TargetMm = 5.0,
    warmup: WarmupOption = True,
    reliable_inputs: ReliableInputs = False,
    *,
    method_options: dict[str, Any],
) -> None:
    """Run the node until SIGINT or SIGTERM: views in, 3D fruit out (docs/ros2.md).

    The domain is ROS_DOMAIN_ID; the network setup is CYCLONEDDS_URI. Every option after --reliable-inputs is
    an option of the bayes method, as in localize.
    """
    options = dict(locals())
    method = method_config("bayes", options.pop("method_options"))
    with _as_flags():
        config = _node_config(options)
    from ..ros2.node import FruitNode, run_until_signal

    run_until_signal(FruitNode(config, method, log=lambda line: console.print(plain(line), highlight=False)))


#: Options of ``ros2 node`` that name a topic (remapped with Topics.with_prefix).
_TOPIC_OPTIONS = (
    "camera_info",
    "detections",
    "tf",
    "tf_static",
    "reset",
    "out_detections",
    "out_markers",
    "out_status",
    "out_next_view",
)


def _node_config(o: dict[str, Any]) -> Any:
    """NodeConfig from the options of ``ros2 node`` (files read, workspace parsed)."""
    from ..io.calibration import read_calibration
    from ..ros2.config import NodeConfig, Topics
    from ..session.load import workspace_from_dict

    ws = workspace_option(o["workspace"])
    return NodeConfig(
        topics=Topics.with_prefix(o["prefix"], **{k: o[k] for k in _TOPIC_OPTIONS}),
        base_frame=o["base_frame"],
        camera_frame=o["camera_frame"],
        pose_frame=o["pose_frame"],
        tool_frame=o["tool_frame"],
        tf_timeout_s=o["tf_timeout"],
        max_gap_s=o["max_gap"],
        camera=read_calibration(o["camera"]) if o["camera"] is not None else None,
        workspace=workspace_from_dict(ws, "--workspace") if ws is not None else None,
        min_score=o["min_score"],
        labels=tuple(o["label"]) if o["label"] else None,
        candidates=o["candidates"],
        target_mm=o["target_mm"],
        warmup=o["warmup"],
        reliable_inputs=o["reliable_inputs"],
    )


@ros2_app.command("play")
@handle_errors
def play_cmd(
    session: Annotated[Path, typer.Argument(help="Session file (JSON/YAML) to publish.")],
    rate: Annotated[float, typer.Option("--rate", help="Views per second.")] = 1.0,
    camera_info: CameraInfoTopic = None,
    detections: DetectionsTopic = None,
    tf: TfTopic = None,
    tf_static: TfStaticTopic = None,
    base_frame: BaseFrame = "base_link",
    tool_frame: Annotated[str, typer.Option("--tool-frame", help="The moving frame (base -> tool on /tf).")] = "tool0",
    camera_frame: Annotated[
        str,
        typer.Option("--camera-frame", help="The camera's optical frame (tool -> camera on /tf_static; the detections' frame)."),
    ] = "camera_optical_frame",
    tf_period: Annotated[float, typer.Option("--tf-period", help="Seconds between TF samples (views fall between two).")] = 0.1,
    tf_delay: Annotated[float, typer.Option("--tf-delay", help="Seconds between a TF sample's stamp and its publication.")] = 0.0,
    sensor_qos: Annotated[
        bool,
        typer.Option("--sensor-qos", help="Publish detections and camera info best effort (SensorDataQoS) rather than reliable."),
    ] = False,
    wait: Annotated[
        float, typer.Option("--wait", help="Seconds to wait for a subscriber of the detections before starting.")
    ] = 10.0,
) -> None:
    """Publish a session as a robot would: camera info, static and moving TF, detections (docs/ros2.md)."""
    from ..ros2.config import Topics
    from ..ros2.play import PlayConfig, play_session
    from ..session.load import load_session

    remap = {"camera_info": camera_info, "detections": detections, "tf": tf, "tf_static": tf_static}
    loaded = load_session(session)
    with _as_flags():
        config = PlayConfig(
            topics=Topics.with_prefix(**remap),
            rate_hz=rate,
            base_frame=base_frame,
            tool_frame=tool_frame,
            camera_frame=camera_frame,
            tf_period_s=tf_period,
            tf_delay_s=tf_delay,
            sensor_qos=sensor_qos,
            wait_s=wait,
        )
    out = play_session(loaded, config, log=lambda line: console.print(plain(line), highlight=False))
    console.print(
        f"published {out['views']} views ({out['messages']} messages) on ROS domain {out['domain_id']}", highlight=False
    )
