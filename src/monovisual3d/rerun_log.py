"""Log a session and its fruit to a rerun recording (``.rrd``; extra ``[rerun]``).

The recording holds, under the entity ``world`` (the robot's base frame, z up):

- ``world/views/NN``: view NN's camera, ``T_base_optical`` as a :class:`rerun.Transform3D` and its
  intrinsics as a :class:`rerun.Pinhole` (optical frame: x right, y down, z forward), logged at
  step NN of the ``view`` timeline, so scrubbing the timeline adds the views one by one;
- ``world/views/NN/boxes``: the view's detection boxes (:class:`rerun.Boxes2D`, pixels) on its image plane;
- ``world/fruit``: the estimated fruit as ellipsoids (sphere of ``radius``, or ``semi_axes`` +
  ``quaternion_xyzw``), labelled with index and score; ``world/fruit_error_95``: their 95 %
  position-error ellipsoids from ``covariance``;
- ``world/truth``: the true fruit when given.

Open the file with ``rerun FILE.rrd`` (the viewer ships with ``rerun-sdk``). The functions take an
explicit :class:`rerun.RecordingStream`, so they never touch rerun's global recording.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ._extras import require
from .figures.html3d.fruits import Fruit, load_fruits
from .figures.html3d.geometry import error_ellipsoid_axes
from .result import Result
from .session import Session, View
from .session.load import load_session
from .truth import ObjectSet, load_objects

if TYPE_CHECKING:  # pragma: no cover
    import rerun as rr

    from .camera import Camera

#: Application id of the recordings written here.
APPLICATION_ID = "monovisual3d"
#: Timeline on which the views are logged (step = view index).
VIEW_TIMELINE = "view"
BOX_COLOUR = (255, 127, 14)
FRUIT_COLOUR = (214, 39, 40)
TRUTH_COLOUR = (44, 160, 44)


def _rerun() -> Any:
    return require("rerun", "rerun")


def log_view(rec: rr.RecordingStream, camera: Camera, view: View, index: int, *, root: str = "world") -> None:
    """Log one view: camera pose, intrinsics and boxes at step ``index`` of the ``view`` timeline.

    Parameters
    ----------
    rec : rerun.RecordingStream
    camera : Camera, the session's camera (distortion is not drawn)
    view : View, with ``T_base_optical`` (4, 4) and its detections
    index : int, the view's index (entity ``{root}/views/{index:02d}``)
    """
    rr = _rerun()
    from scipy.spatial.transform import Rotation

    T = view.T_base_optical
    path = f"{root}/views/{index:02d}"
    rec.set_time(VIEW_TIMELINE, sequence=index)
    rec.log(
        path,
        rr.Transform3D(translation=T[:3, 3], quaternion=rr.Quaternion(xyzw=Rotation.from_matrix(T[:3, :3]).as_quat())),
    )
    rec.log(
        path,
        rr.Pinhole(image_from_camera=camera.K, resolution=[camera.width, camera.height], camera_xyz=rr.ViewCoordinates.RDF),
    )
    boxes = view.boxes_xyxy
    labels = [f"#{j}" + (f" {d.score:.2f}" if d.score is not None else "") for j, d in enumerate(view.detections)]
    rec.log(
        f"{path}/boxes",
        rr.Boxes2D(array=boxes, array_format=rr.Box2DFormat.XYXY, colors=[BOX_COLOUR] * len(boxes), labels=labels),
    )


def log_fruits(rec: rr.RecordingStream, fruits: list[Fruit], *, root: str = "world") -> None:
    """Log estimated fruit as ellipsoids at ``{root}/fruit`` and their 95 % error ellipsoids at ``{root}/fruit_error_95``.

    Fruit without a size are drawn as 5 mm spheres.
    """
    rr = _rerun()
    from scipy.spatial.transform import Rotation

    if not fruits:
        rec.log(f"{root}/fruit", rr.Ellipsoids3D(centers=np.zeros((0, 3)), half_sizes=np.zeros((0, 3))))
        return
    centres = np.array([f.position for f in fruits])
    half = np.array([f.semi_axes if f.semi_axes is not None else np.full(3, 0.005) for f in fruits])
    quats = [rr.Quaternion(xyzw=Rotation.from_matrix(f.R_base_fruit).as_quat()) for f in fruits]
    labels = [f"fruit {k} ({f.score:.3g})" for k, f in enumerate(fruits)]
    rec.log(
        f"{root}/fruit",
        rr.Ellipsoids3D(
            centers=centres,
            half_sizes=half,
            quaternions=quats,
            colors=[FRUIT_COLOUR] * len(fruits),
            labels=labels,
            fill_mode=rr.components.FillMode.Solid,
        ),
    )
    with_cov = [f for f in fruits if f.covariance is not None]
    if with_cov:
        axes = [error_ellipsoid_axes(f.covariance) for f in with_cov]
        rec.log(
            f"{root}/fruit_error_95",
            rr.Ellipsoids3D(
                centers=np.array([f.position for f in with_cov]),
                half_sizes=np.array([np.maximum(a, 1e-5) for a, _ in axes]),
                quaternions=[rr.Quaternion(xyzw=Rotation.from_matrix(R).as_quat()) for _, R in axes],
                colors=[FRUIT_COLOUR + (80,)] * len(with_cov),
            ),
        )


def log_session(
    rec: rr.RecordingStream,
    session: Session | str | Path | dict[str, Any],
    result: Result | str | Path | dict[str, Any] | None = None,
    truth: ObjectSet | str | Path | dict[str, Any] | None = None,
    *,
    root: str = "world",
) -> None:
    """Log every view of a session, then (at the last view's step) the fruit and the truth."""
    rr = _rerun()
    session = load_session(session)
    rec.log(root, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for i, view in enumerate(session.views):
        log_view(rec, session.camera, view, i, root=root)
    if result is not None:
        log_fruits(rec, load_fruits(result), root=root)
    if truth is not None:
        tru = truth if isinstance(truth, ObjectSet) else load_objects(truth)
        radii = np.where(np.isfinite(tru.radii), tru.radii, 0.005)
        rec.log(
            f"{root}/truth",
            rr.Ellipsoids3D(
                centers=tru.positions,
                half_sizes=np.repeat(radii[:, None], 3, axis=1),
                colors=[TRUTH_COLOUR] * len(radii),
                labels=[f"true fruit {t}" for t in range(len(radii))],
            ),
        )


def write_rrd(
    session: Session | str | Path | dict[str, Any],
    result: Result | str | Path | dict[str, Any] | None = None,
    truth: ObjectSet | str | Path | dict[str, Any] | None = None,
    *,
    path: str | Path = "session.rrd",
) -> Path:
    """Write :func:`log_session` to a new ``.rrd`` file and return its path.

    Examples
    --------
    >>> import tempfile, os
    >>> from monovisual3d.examples import example_session_path
    >>> p = write_rrd(example_session_path(), path=os.path.join(tempfile.mkdtemp(), "s.rrd"))  # doctest: +SKIP
    >>> p.stat().st_size > 0  # doctest: +SKIP
    True
    """
    rr = _rerun()
    session = load_session(session)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    log_session(rec, session, result, truth)
    rec.flush()
    rec.disconnect()
    return path
