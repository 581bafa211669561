"""Drawing helpers of the matplotlib 3D panels: sphere wireframes, camera frusta, occluders, equal axes.

Positions are metres in the base frame. The functions draw on a given axes and return nothing
(except :func:`frustum_lines`, pure geometry).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..sim.scene import Leaf, Stem
from ._style import CAMERA_COLOUR, NUMBER_SIZE, OCCLUDER_COLOUR, STEM_COLOUR, TICK_SIZE

if TYPE_CHECKING:  # pragma: no cover
    from ..camera import Camera


def sphere_mesh(
    centre: NDArray[np.float64], radius: float, n_u: int = 14, n_v: int = 8
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Wireframe mesh of a sphere, three arrays of shape (n_v, n_u), metres."""
    u = np.linspace(0.0, 2 * np.pi, n_u)
    v = np.linspace(0.0, np.pi, n_v)
    x = centre[0] + radius * np.outer(np.sin(v), np.cos(u))
    y = centre[1] + radius * np.outer(np.sin(v), np.sin(u))
    z = centre[2] + radius * np.outer(np.cos(v), np.ones_like(u))
    return x, y, z


def frustum_lines(camera: Camera, T_base_optical: ArrayLike, depth: float = 0.08) -> NDArray[np.float64]:
    """Edges of a small camera frustum, shape (8, 2, 3), metres, base frame.

    Four edges from the optical centre to the image corners at ``depth`` along
    the optical axis, and the four edges of the image rectangle there.

    Examples
    --------
    >>> from monovisual3d.camera import Camera
    >>> frustum_lines(Camera.from_hfov(640, 480, 69.0), np.eye(4)).shape
    (8, 2, 3)
    """
    T = np.asarray(T_base_optical, dtype=float)
    if T.shape != (4, 4):
        raise InputError(f"T_base_optical: expected shape (4, 4), got {T.shape}")
    corners_uv = np.array([[0.0, 0.0], [camera.width, 0.0], [camera.width, camera.height], [0.0, camera.height]])
    xy = (corners_uv - [camera.cx, camera.cy]) / [camera.fx, camera.fy]
    p_optical = depth * np.column_stack([xy, np.ones(4)])
    p_base = p_optical @ T[:3, :3].T + T[:3, 3]
    origin = T[:3, 3]
    edges = [(origin, p_base[i]) for i in range(4)] + [(p_base[i], p_base[(i + 1) % 4]) for i in range(4)]
    return np.array(edges)


def set_equal_3d(ax: Any, points: NDArray[np.float64], margin: float = 0.03, zoom: float = 0.8) -> None:
    """Equal scale on the three axes around ``points`` (N, 3).

    ``zoom`` < 1 shrinks the cube inside its axes box so that the tick and axis labels (z on the left,
    x and y at the bottom) stay inside the figure; at 1 the z label is cut off at the figure's left edge.
    """
    lo, hi = points.min(axis=0) - margin, points.max(axis=0) + margin
    centre, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1), zoom=zoom)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))  # fewer ticks: the x and y labels collide at the bottom corner
    ax.tick_params(labelsize=TICK_SIZE)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.zaxis.set_rotate_label(False)  # matplotlib's default turns "z (m)" upside down in this view
    ax.set_zlabel("z (m)", rotation=90)


def draw_spheres(ax: Any, centres: NDArray[np.float64], radii: NDArray[np.float64], **style: Any) -> None:
    """Wireframe spheres at ``centres`` (N, 3) with ``radii`` (N,), metres, drawn with matplotlib ``style``."""
    for c, r in zip(centres, radii):
        ax.plot_wireframe(*sphere_mesh(c, float(r)), **style)


def draw_cameras(ax: Any, camera: Camera, poses: NDArray[np.float64], depth: float, first: int = 0) -> None:
    """Frusta of ``poses`` (N, 4, 4), each numbered on a white tag, from ``first`` (0: the view index of
    ``session.json`` and ``view_NN.png``; 1: "after view 1" of the posterior snapshots)."""
    for i, T in enumerate(poses, start=first):
        for a, b in frustum_lines(camera, T, depth):
            ax.plot(*np.stack([a, b]).T, color=CAMERA_COLOUR, linewidth=1.0)
        ax.text(
            *T[:3, 3],
            f"{i}",
            color=CAMERA_COLOUR,
            fontsize=NUMBER_SIZE,
            fontweight="bold",
            ha="center",
            va="center",
            bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": CAMERA_COLOUR, "alpha": 0.9},
            zorder=10,
        )


def draw_occluders(ax: Any, occluders: Sequence[Any]) -> None:
    """Leaves as their outlines and stems as lines, in 3D."""
    for o in occluders:
        if isinstance(o, Leaf):
            hu, hv = o.half_size
            corners = [
                o.centre + su * hu * o.axis_u + sv * hv * o.axis_v for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))
            ]
            ax.plot(*np.array(corners).T, color=OCCLUDER_COLOUR, linewidth=1.2)
        elif isinstance(o, Stem):
            ax.plot(*np.stack([o.start, o.end]).T, color=STEM_COLOUR, linewidth=1.5)


def draw_occluder_2d(ax: Any, o: Any, dims: tuple[int, int]) -> None:
    """An occluder projected on the base-frame plane spanned by axes ``dims`` (e.g. (1, 2): y-z)."""
    a, b = dims
    if isinstance(o, Leaf):
        hu, hv = o.half_size
        corners = np.array(
            [o.centre + su * hu * o.axis_u + sv * hv * o.axis_v for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))]
        )
        ax.fill(corners[:, a], corners[:, b], color=OCCLUDER_COLOUR, alpha=0.25, linewidth=0.8)
    elif isinstance(o, Stem):
        ax.plot([o.start[a], o.end[a]], [o.start[b], o.end[b]], color=STEM_COLOUR, linewidth=1.5)
