"""``import``, ``import-bag`` and ``import-lfd``: build a session file from real-world data."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ..errors import InputError, one_line
from ._app import app, check_output, command_budget, console, handle_errors, json_text, plain, write_output
from .options import LfdImageSize, MaxMemory, TimeLimit

if TYPE_CHECKING:
    from ..io.summary import ImportResult


def _size(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    from ..io.image_size import parse_image_size

    return parse_image_size(text)


def _crop(text: str | None) -> list[float] | None:
    if text is None:
        return None
    parts = text.replace("x", ",").split(",")
    if len(parts) != 4:
        raise InputError(f"--crop: got {text!r}, expected X1,Y1,X2,Y2 in calibration pixels")
    try:
        return [float(p) for p in parts]
    except ValueError:
        raise InputError(f"--crop: got {text!r}, expected four numbers X1,Y1,X2,Y2") from None


def workspace_option(text: str | None) -> dict[str, list[float]] | None:
    """``--workspace XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX`` (metres) as a session workspace dict; None when not given."""
    if text is None:
        return None
    try:
        v = [float(p) for p in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 6:
        raise InputError(f"--workspace: got {text!r}, expected XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX in metres")
    return {"min": v[:3], "max": v[3:]}


def _report(result: ImportResult, output: Path) -> None:
    write_output(output, result.session.to_json() + "\n")
    console.print(f"wrote {plain(one_line(str(output)))}", highlight=False)
    for line in result.summary.lines():
        console.print(f"  {line}", highlight=False, markup=False, soft_wrap=True)


#: ``--camera`` of ``import``.
CameraOption = Annotated[
    Path, typer.Option("--camera", help="Calibration: Kalibr, ROS camera_info, OpenCV, DepthAI or session camera.")
]
#: ``--hand-eye`` of ``import``.
HandEyeOption = Annotated[
    Path | None, typer.Option("--hand-eye", help="T_ee_camera (eye-in-hand); the poses are then end-effector poses.")
]
#: ``--camera-format`` of ``import``.
CameraFormatOption = Annotated[str | None, typer.Option("--camera-format", help="kalibr, ros, opencv, depthai, monovisual3d.")]
#: ``--camera-name`` of ``import``.
CameraNameOption = Annotated[
    str | None, typer.Option("--camera-name", help="Kalibr cam0/cam1..., DepthAI socket (CAM_A, rgb...).")
]
#: ``--image-size`` of ``import`` and ``import-bag``.
ImageSizeOption = Annotated[
    str | None, typer.Option("--image-size", help="Size of the detector's images, WxH, if not the calibration's.")
]
#: ``--crop`` of ``import``.
CropOption = Annotated[
    str | None, typer.Option("--crop", help="Region of the calibration image the images were cut from: X1,Y1,X2,Y2.")
]
#: ``--pose-frame`` of ``import``.
PoseFrameOption = Annotated[str, typer.Option("--pose-frame", help="Camera frame of the poses: optical or camera_link.")]
#: ``--class-names`` of ``import``.
ClassNamesOption = Annotated[Path | None, typer.Option("--class-names", help="Class names: data.yaml, classes.txt or JSON.")]
#: ``--coco-images`` of ``import``.
CocoImagesOption = Annotated[
    Path | None, typer.Option("--coco-images", help="COCO file with the images list, for a bare COCO results list.")
]
#: ``--max-gap`` of ``import``.
MaxGapOption = Annotated[float, typer.Option("--max-gap", help="Largest time (s) between an image and the poses used for it.")]
#: ``--workspace`` of ``import`` and ``import-bag``.
WorkspaceOption = Annotated[str | None, typer.Option("--workspace", help="XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX in metres, base frame.")]
#: ``--resize`` of ``import`` and ``import-bag``.
ResizeOption = Annotated[str, typer.Option("--resize", help="How the images were resized: auto, stretch, crop (centre).")]
#: ``--label`` of ``import`` and ``import-bag``.
LabelOption = Annotated[list[str] | None, typer.Option("--label", help="Keep only this label (repeatable).")]
#: ``--min-score`` of ``import`` and ``import-bag``.
MinScoreOption = Annotated[float | None, typer.Option("--min-score", help="Drop detections scored below this.")]


@app.command(name="import")
@handle_errors
def import_cmd(
    camera: CameraOption,
    poses: Annotated[Path, typer.Option("--poses", help="Poses: TUM (.txt), CSV or JSON list of 4x4 matrices.")],
    detections: Annotated[Path, typer.Option("--detections", help="YOLO label folder/file, COCO JSON or CSV.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Session file to write (JSON).")],
    hand_eye: HandEyeOption = None,
    camera_format: CameraFormatOption = None,
    camera_name: CameraNameOption = None,
    image_size: ImageSizeOption = None,
    resize: ResizeOption = "auto",
    crop: CropOption = None,
    pose_format: Annotated[str | None, typer.Option("--pose-format", help="tum, csv or json (default: by suffix).")] = None,
    units: Annotated[str, typer.Option("--units", help="Unit of positions in the pose file: m, mm, cm.")] = "m",
    hand_eye_units: Annotated[str, typer.Option("--hand-eye-units", help="Unit of the hand-eye translation: m, mm, cm.")] = "m",
    pose_frame: PoseFrameOption = "optical",
    detections_format: Annotated[str | None, typer.Option("--detections-format", help="yolo, coco or csv.")] = None,
    class_names: ClassNamesOption = None,
    coco_images: CocoImagesOption = None,
    label: LabelOption = None,
    min_score: MinScoreOption = None,
    match: Annotated[str, typer.Option("--match", help="Pair poses and images by: auto, name, stamp, order.")] = "auto",
    max_gap: MaxGapOption = 0.1,
    time_offset: Annotated[
        str,
        typer.Option(
            "--time-offset",
            help="Seconds the pose stream runs ahead of the images (poses looked up at each image stamp minus it), "
            "or auto: estimated from the boxes (needs stamps; not applied where the views cannot tell it).",
        ),
    ] = "0",
    workspace: WorkspaceOption = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Build a session file from a calibration, poses and detections, and print what was skipped.

    One unit of thought: the importer's options, one per input format, passed through as they are.
    """
    from ..io.build import import_session

    check_output(output, camera, poses, detections, hand_eye, class_names, coco_images)
    with command_budget(time_limit, max_memory):
        result = import_session(
            camera,
            poses,
            detections,
            hand_eye=hand_eye,
            camera_format=camera_format,
            camera_name=camera_name,
            image_size=_size(image_size),
            resize=resize,
            crop_xyxy=_crop(crop),
            pose_format=pose_format,
            units=units,
            hand_eye_units=hand_eye_units,
            pose_frame=pose_frame,
            detections_format=detections_format,
            class_names=class_names,
            coco_images=coco_images,
            labels=label or None,
            min_score=min_score,
            match=match,
            max_gap=max_gap,
            workspace=workspace_option(workspace),
            time_offset=time_offset if time_offset == "auto" else float(_seconds(time_offset)),
        )
    _report(result, output)


def _seconds(text: str) -> float:
    """``--time-offset``'s value as seconds (InputError naming the flag otherwise)."""
    try:
        return float(text)
    except ValueError:
        raise InputError(f"--time-offset: got {text!r}, expected seconds or auto") from None


@app.command(name="import-bag")
@handle_errors
def import_bag_cmd(
    bag: Annotated[Path, typer.Argument(help="ROS 1 .bag file or ROS 2 bag folder (sqlite3 or MCAP).")],
    base_frame: Annotated[str, typer.Option("--base-frame", help="Robot base frame in TF.")],
    camera_frame: Annotated[str, typer.Option("--camera-frame", help="Camera frame in TF (optical frame by default).")],
    detections: Annotated[str, typer.Option("--detections", help="vision_msgs/Detection2DArray topic.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Session file to write (JSON).")],
    camera_info: Annotated[
        str | None, typer.Option("--camera-info", help="sensor_msgs/CameraInfo topic (found if only one).")
    ] = None,
    camera: Annotated[Path | None, typer.Option("--camera", help="Calibration file to use instead of camera_info.")] = None,
    pose_frame: Annotated[
        str, typer.Option("--pose-frame", help="Convention of --camera-frame: optical or camera_link.")
    ] = "optical",
    image_size: ImageSizeOption = None,
    resize: ResizeOption = "auto",
    class_names: Annotated[
        Path | None, typer.Option("--class-names", help="Names of numeric class ids: data.yaml, classes.txt or JSON.")
    ] = None,
    label: LabelOption = None,
    min_score: MinScoreOption = None,
    max_gap: Annotated[
        float, typer.Option("--max-gap", help="Largest time (s) between a detection and the TF samples used.")
    ] = 0.1,
    workspace: WorkspaceOption = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Build a session file from a ROS bag: TF poses, CameraInfo and Detection2DArray."""
    from ..io.rosbag import read_bag

    check_output(output, bag, camera, class_names)
    with command_budget(time_limit, max_memory):
        result = read_bag(
            bag,
            base_frame=base_frame,
            camera_frame=camera_frame,
            detections_topic=detections,
            camera_info_topic=camera_info,
            camera=camera,
            pose_frame=pose_frame,
            max_gap=max_gap,
            min_score=min_score,
            labels=label or None,
            class_names=class_names,
            image_size=_size(image_size),
            resize=resize,
            workspace=workspace_option(workspace),
        )
    _report(result, output)


@app.command(name="import-lfd")
@handle_errors
def import_lfd_cmd(
    folder: Annotated[
        Path, typer.Argument(help="Folder of LfD arrays: intrinsics, camera_poses, bounding_boxes, visibility (.npy).")
    ],
    output: Annotated[Path, typer.Option("--output", "-o", help="Session file to write (JSON).")],
    truth: Annotated[
        Path | None, typer.Option("--truth", help="Also write the truth (centres, semi-axes, orientation from gt.npy) here.")
    ] = None,
    keep_association: Annotated[
        bool, typer.Option("--keep-association", help="Write each box's object index as its track id (default: pooled).")
    ] = False,
    image_size: LfdImageSize = None,
    time_limit: TimeLimit = None,
    max_memory: MaxMemory = None,
) -> None:
    """Build a session (and a truth file) from the LfD .npy layout; boxes pooled per view, sorted by x_min."""
    from ..io.lfd import read_lfd

    check_output(output, folder)
    check_output(truth, folder, output, flag="--truth")
    if truth is not None and output.resolve() == truth.resolve():
        raise InputError(f"{one_line(str(truth))}: also the --output file, choose another --truth")
    with command_budget(time_limit, max_memory):
        session, truth_data = read_lfd(
            folder, keep_association=keep_association, truth=truth is not None, image_size=_size(image_size)
        )
    write_output(output, session.to_json() + "\n")
    n_boxes = sum(len(v.detections) for v in session.views)
    how = "track ids from the columns" if keep_association else "pooled per view, sorted by x_min"
    console.print(f"wrote {plain(str(output))}: {len(session.views)} views, {n_boxes} boxes ({how})", highlight=False)
    if truth is not None and truth_data is not None:
        write_output(truth, json_text(truth_data) + "\n")
        console.print(f"wrote {plain(str(truth))}: {len(truth_data['objects'])} objects", highlight=False)
