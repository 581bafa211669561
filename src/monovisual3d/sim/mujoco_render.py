"""Photorealistic views of a :class:`~monovisual3d.sim.scene.Scene`, rendered with MuJoCo (extra ``[sim]``).

The scene becomes an MJCF model: red spheres or ellipsoids for the fruit, thin green boxes
for the leaves, brown cylinders for the stems, a ground plane, a sky and two
lights. The camera hangs on a mocap body, so moving it costs no recompilation.
Each view gives an RGB image and a label image (the fruit index of every pixel,
``-1`` where no fruit is seen), from which the boxes of the visible parts of
the fruit follow (:func:`monovisual3d.vision.boxes_from_label_image`).

Camera model
------------
The rendered image follows the project's pinhole :class:`~monovisual3d.camera.Camera`
exactly, principal point offsets and ``fx != fy`` included: after MuJoCo has set
up its OpenGL camera, the frustum is overwritten with the one computed from
``fx, fy, cx, cy`` (:func:`frustum_from_camera`). OpenGL puts pixel centres at
integer + 0.5, as this project does. Lens distortion cannot be rasterised and is
refused. The MJCF camera also carries the intrinsics (``sensorsize``,
``focalpixel``, ``principalpixel``, ``resolution``) so that a saved model shows
the same view in MuJoCo's viewer. MuJoCo measures ``principalpixel`` on the
physical, inverted sensor, so it is ``(width / 2 - cx, height / 2 - cy)``
(measured with MuJoCo 4.0).

MuJoCo cameras look along their -z axis with +y up; the optical frame looks
along +z with +y down, so ``T_base_mjcam = T_base_optical @ diag(1, -1, -1, 1)``.

Offscreen OpenGL
----------------
MuJoCo chooses its OpenGL backend from the environment variable ``MUJOCO_GL``
once, when ``mujoco`` is first imported. When it is unset,
:func:`select_gl_backend` (called before this module imports mujoco) tries
``egl`` and then ``osmesa`` in a short-lived subprocess and sets ``MUJOCO_GL`` to
the first that creates a context. Set ``MUJOCO_GL`` yourself, before anything
imports mujoco, to skip the probe. On Debian/Ubuntu, EGL comes with
``libegl1`` (plus a GPU driver, or Mesa's software ``llvmpipe``) and OSMesa
with ``libosmesa6``.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._extras import require
from ..camera import Camera
from ..errors import InputError
from ..frames import check_transform, position_quaternion_from_transform
from .scene import EllipsoidFruit, Leaf, Scene, Stem

#: OpenGL backends tried, in order, when ``MUJOCO_GL`` is unset.
GL_BACKENDS = ("egl", "osmesa")

#: ``T_optical_mjcam``: MuJoCo's camera frame (x right, y up, looking along -z) in the optical frame.
T_OPTICAL_MJCAM = np.diag([1.0, -1.0, -1.0, 1.0])

_PROBE_CODE = "import mujoco; c = mujoco.GLContext(16, 16); c.make_current(); c.free()"
_probe_results: dict[str, bool] = {}


# ---------------------------------------------------------------------- OpenGL backend
def gl_backend_works(backend: str, timeout_s: float = 60.0) -> bool:
    """True if MuJoCo can create an offscreen OpenGL context with ``backend``.

    Runs the check in a subprocess, because the backend of a process is fixed
    when mujoco is imported. Results are remembered for the process.

    Parameters
    ----------
    backend : str, a value of ``MUJOCO_GL`` (``egl``, ``osmesa``, ``glfw``)
    timeout_s : float, seconds before the check counts as failed
    """
    if backend not in _probe_results:
        env = dict(os.environ, MUJOCO_GL=backend)
        env.pop("PYOPENGL_PLATFORM", None)
        try:
            proc = subprocess.run(
                [sys.executable, "-c", _PROBE_CODE], env=env, capture_output=True, timeout=timeout_s, check=False
            )
            _probe_results[backend] = proc.returncode == 0
        except (OSError, subprocess.TimeoutExpired):
            _probe_results[backend] = False
    return _probe_results[backend]


def select_gl_backend(candidates: tuple[str, ...] = GL_BACKENDS) -> str:
    """Set ``MUJOCO_GL`` to the first working backend unless it is already set.

    Must run before mujoco is imported (this module calls it before its own
    import). With ``MUJOCO_GL`` already set, or mujoco already imported, nothing
    changes and the current value is returned.

    Parameters
    ----------
    candidates : tuple of str, backends to try in order

    Returns
    -------
    backend : str, the value of ``MUJOCO_GL`` (``""`` if mujoco was imported without it)

    Raises
    ------
    RuntimeError
        If no candidate creates a context; the message names the system packages to install.
    """
    current = os.environ.get("MUJOCO_GL", "")
    if current or "mujoco" in sys.modules:
        return current
    for backend in candidates:
        if gl_backend_works(backend):
            os.environ["MUJOCO_GL"] = backend
            return backend
    raise RuntimeError(
        f"MuJoCo could not create an offscreen OpenGL context with any of {list(candidates)}: "
        "install EGL (Debian/Ubuntu: libegl1 and a GPU driver or Mesa) or OSMesa (libosmesa6), "
        "or set MUJOCO_GL before importing mujoco"
    )


def _import_mujoco() -> ModuleType:
    if importlib.util.find_spec("mujoco") is not None:
        select_gl_backend()
    return require("mujoco", "sim")  # without mujoco: ImportError naming the extra


# ---------------------------------------------------------------------- geometry
def T_base_mjcam_from_T_base_optical(T_base_optical: ArrayLike) -> NDArray[np.float64]:
    """MuJoCo camera pose (looks along -z, y up) from the optical pose (looks along +z, y down).

    Parameters
    ----------
    T_base_optical : array_like, shape (4, 4)

    Returns
    -------
    T_base_mjcam : ndarray, shape (4, 4)

    Examples
    --------
    >>> T_base_mjcam_from_T_base_optical(np.eye(4))[:3, 2]  # MuJoCo z points backwards
    array([ 0.,  0., -1.])
    """
    return np.asarray(T_base_optical, dtype=float) @ T_OPTICAL_MJCAM


def frustum_from_camera(camera: Camera, near: float) -> dict[str, float]:
    """OpenGL frustum (MuJoCo ``mjvGLCamera`` fields) that reproduces a pinhole camera.

    On the near plane, in MuJoCo's camera frame (x right, y up), the image spans
    ``x in [-cx, width - cx] * near / fx`` and ``y in [-(height - cy), cy] * near / fy``.

    Parameters
    ----------
    camera : Camera, without distortion
    near : float, distance of the near clipping plane, metres

    Returns
    -------
    frustum : dict with ``frustum_center``, ``frustum_width`` (half width),
        ``frustum_bottom``, ``frustum_top``, ``frustum_near``, metres

    Examples
    --------
    >>> f = frustum_from_camera(Camera(320, 240, 300.0, 300.0, 160.0, 120.0), 0.01)
    >>> round(f["frustum_width"], 6), f["frustum_center"]
    (0.005333, 0.0)
    """
    if not near > 0:
        raise InputError(f"near: got {near}, expected a positive distance in metres")
    w, h = camera.width, camera.height
    return {
        "frustum_center": (0.5 * w - camera.cx) * near / camera.fx,
        "frustum_width": 0.5 * w * near / camera.fx,
        "frustum_bottom": -(h - camera.cy) * near / camera.fy,
        "frustum_top": camera.cy * near / camera.fy,
        "frustum_near": near,
    }


# ---------------------------------------------------------------------- MJCF
@dataclass(frozen=True)
class RenderConfig:
    """Appearance of the rendered scene.

    Attributes
    ----------
    fruit_rgba, leaf_rgba, stem_rgba, ground_rgba : tuple of 4 floats in [0, 1]
    sky_rgb_top, sky_rgb_bottom : tuple of 3 floats, gradient of the background
    ground : bool, draw a ground plane
    ground_z : float or None, height of the ground, metres, base frame; None puts it
        ``ground_margin`` below the lowest point of the scene (and
        :func:`~monovisual3d.sim.photoreal.render_views` also below the lowest camera)
    ground_margin : float, metres
    leaf_thickness : float, metres (leaves are thin boxes so both sides render)
    shadows : bool, the main light casts shadows
    sphere_slices : int, tessellation of spheres and cylinders (MuJoCo ``numslices``/``numstacks``);
        the polygonal silhouette of a sphere of r pixels loses ``r * (1 - cos(pi / slices))`` px
    multisamples : int, anti-aliasing samples of the RGB image (segmentation is not blended)
    near_m, far_m : float, clipping distances, metres
    """

    fruit_rgba: tuple[float, float, float, float] = (0.78, 0.06, 0.04, 1.0)
    leaf_rgba: tuple[float, float, float, float] = (0.16, 0.45, 0.12, 1.0)
    stem_rgba: tuple[float, float, float, float] = (0.35, 0.28, 0.12, 1.0)
    ground_rgba: tuple[float, float, float, float] = (0.32, 0.34, 0.30, 1.0)
    sky_rgb_top: tuple[float, float, float] = (0.78, 0.86, 0.95)
    sky_rgb_bottom: tuple[float, float, float] = (0.45, 0.52, 0.58)
    ground: bool = True
    ground_z: float | None = None
    ground_margin: float = 0.3
    leaf_thickness: float = 0.001
    shadows: bool = True
    sphere_slices: int = 96
    multisamples: int = 4
    near_m: float = 0.01
    far_m: float = 50.0

    def __post_init__(self) -> None:
        if not 0 < self.near_m < self.far_m:
            raise InputError(f"near_m, far_m: got {self.near_m}, {self.far_m}, expected 0 < near_m < far_m")
        if self.sphere_slices < 8:
            raise InputError(f"sphere_slices: got {self.sphere_slices}, expected at least 8")
        if self.leaf_thickness <= 0:
            raise InputError(f"leaf_thickness: got {self.leaf_thickness}, expected a positive thickness in metres")


def scene_lowest_z(scene: Scene) -> float:
    """Lowest z (metres, base frame) of any fruit or occluder; 0 for an empty scene."""
    lows: list[float] = [
        float(f.centre[2] - np.sqrt(np.sum((f.rotation[2] * f.semi_axes) ** 2)))
        if isinstance(f, EllipsoidFruit)
        else float(f.centre[2] - f.radius)
        for f in scene.fruits
    ]
    for occ in scene.occluders:
        if isinstance(occ, Leaf):
            hu, hv = occ.half_size
            lows.append(float(occ.centre[2] - abs(hu * occ.axis_u[2]) - abs(hv * occ.axis_v[2])))
        elif isinstance(occ, Stem):
            lows.append(float(min(occ.start[2], occ.end[2]) - occ.radius))
    return min(lows) if lows else 0.0


def _fmt(values: ArrayLike) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def mjcf_from_scene(scene: Scene, camera: Camera, config: RenderConfig | None = None) -> str:
    """MJCF text of a scene with a camera named ``camera`` on the mocap body ``camera_mount``.

    Geoms are named ``fruit_<i>`` (i = index in ``scene.fruits``), ``leaf_<i>``,
    ``stem_<i>`` and ``ground``.

    Parameters
    ----------
    scene : Scene
    camera : Camera, without distortion
    config : RenderConfig or None (defaults)

    Returns
    -------
    xml : str

    Examples
    --------
    >>> from monovisual3d.sim.scene import Sphere
    >>> xml = mjcf_from_scene(Scene((Sphere(np.array([0.5, 0.0, 0.3]), 0.03),)), Camera.from_hfov(320, 240, 60.0))
    >>> 'name="fruit_0"' in xml
    True
    """
    cfg = config or RenderConfig()
    check_renderable_camera(camera)
    root = ET.Element("mujoco", model=f"monovisual3d_{scene.name}")
    ET.SubElement(root, "compiler", angle="radian")
    # extent 1 makes znear/zfar absolute distances; the centre anchors the directional light's shadow map
    centre = scene.centres.mean(axis=0) if scene.fruits else np.zeros(3)
    ET.SubElement(root, "statistic", extent="1", center=_fmt(centre))
    _add_visual(root, camera, cfg)
    _add_assets(root, cfg)
    world = ET.SubElement(root, "worldbody")
    _add_light_and_ground(world, scene, cfg)
    _add_fruits(world, scene)
    _add_occluders(world, scene, cfg)
    _add_camera(world, camera)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


def _add_visual(root: ET.Element, camera: Camera, cfg: RenderConfig) -> None:
    """Offscreen buffer of the camera's size, anti-aliasing, tessellation, clipping, shadow map and headlight."""
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "global", offwidth=str(camera.width), offheight=str(camera.height))
    ET.SubElement(
        visual,
        "quality",
        shadowsize="4096",
        offsamples=str(int(cfg.multisamples)),
        numslices=str(int(cfg.sphere_slices)),
        numstacks=str(int(cfg.sphere_slices)),
    )
    # shadowclip 3 (metres, with extent 1): the directional shadow map covers the scene without acne
    ET.SubElement(visual, "map", znear=f"{cfg.near_m:.9g}", zfar=f"{cfg.far_m:.9g}", shadowclip="3")
    ET.SubElement(visual, "headlight", ambient="0.35 0.35 0.35", diffuse="0.35 0.35 0.35", specular="0 0 0")


def _add_light_and_ground(world: ET.Element, scene: Scene, cfg: RenderConfig) -> None:
    """The sun (a directional light, shadows if ``cfg.shadows``) and the ground plane below the scene (``cfg.ground``)."""
    ET.SubElement(
        world,
        "light",
        name="sun",
        directional="true",
        pos="0 0 5",
        dir="0.3 0.2 -1",
        diffuse="0.6 0.6 0.6",
        specular="0.1 0.1 0.1",
        castshadow="true" if cfg.shadows else "false",
    )
    if cfg.ground:
        ground_z = cfg.ground_z if cfg.ground_z is not None else scene_lowest_z(scene) - cfg.ground_margin
        ET.SubElement(world, "geom", name="ground", type="plane", size="0 0 0.05", pos=f"0 0 {ground_z:.9g}", material="ground")


def _add_camera(world: ET.Element, camera: Camera) -> None:
    """The camera ``camera`` on the mocap body ``camera_mount``, with the pinhole's focal lengths and principal point."""
    w, h = camera.width, camera.height
    mount = ET.SubElement(world, "body", name="camera_mount", mocap="true")
    ET.SubElement(
        mount,
        "camera",
        name="camera",
        resolution=f"{w} {h}",
        sensorsize=_fmt([w * 1e-5, h * 1e-5]),
        focalpixel=_fmt([camera.fx, camera.fy]),
        principalpixel=_fmt([0.5 * w - camera.cx, 0.5 * h - camera.cy]),
    )


def _add_assets(root: ET.Element, cfg: RenderConfig) -> None:
    """Sky, ground texture and the materials of fruit, leaves and stems."""
    asset = ET.SubElement(root, "asset")
    ET.SubElement(
        asset,
        "texture",
        name="sky",
        type="skybox",
        builtin="gradient",
        rgb1=_fmt(cfg.sky_rgb_top),
        rgb2=_fmt(cfg.sky_rgb_bottom),
        width="256",
        height="256",
    )
    g = np.asarray(cfg.ground_rgba[:3])
    ET.SubElement(
        asset,
        "texture",
        name="ground",
        type="2d",
        builtin="checker",
        rgb1=_fmt(g),
        rgb2=_fmt(0.85 * g),
        width="256",
        height="256",
    )
    ET.SubElement(asset, "material", name="ground", texture="ground", texrepeat="10 10", reflectance="0")
    ET.SubElement(asset, "material", name="fruit", rgba=_fmt(cfg.fruit_rgba), specular="0.2", shininess="0.3")
    ET.SubElement(asset, "material", name="leaf", rgba=_fmt(cfg.leaf_rgba), specular="0.05")
    ET.SubElement(asset, "material", name="stem", rgba=_fmt(cfg.stem_rgba), specular="0.05")


def _add_fruits(world: ET.Element, scene: Scene) -> None:
    """One geom per fruit: a sphere, or an ellipsoid for :class:`EllipsoidFruit`."""
    for i, fruit in enumerate(scene.fruits):
        if isinstance(fruit, EllipsoidFruit):  # validated on construction
            ET.SubElement(
                world,
                "geom",
                name=f"fruit_{i}",
                type="ellipsoid",
                size=_fmt(fruit.semi_axes),
                pos=_fmt(fruit.centre),
                quat=_fmt(np.roll(fruit.quaternion_xyzw, 1)),  # MuJoCo quaternions are (w, x, y, z)
                material="fruit",
            )
            continue
        if not fruit.radius > 0:
            raise InputError(f"scene.objects[{i}].radius: got {fruit.radius}, expected a positive radius in metres")
        ET.SubElement(
            world, "geom", name=f"fruit_{i}", type="sphere", size=f"{fruit.radius:.9g}", pos=_fmt(fruit.centre), material="fruit"
        )


def _add_occluders(world: ET.Element, scene: Scene, cfg: RenderConfig) -> None:
    """Leaves as thin boxes, stems as cylinders (visual only: no contacts)."""
    for i, occ in enumerate(scene.occluders):
        if isinstance(occ, Leaf):
            hu, hv = occ.half_size
            ET.SubElement(
                world,
                "geom",
                name=f"leaf_{i}",
                type="box",
                size=_fmt([hu, hv, 0.5 * cfg.leaf_thickness]),
                pos=_fmt(occ.centre),
                xyaxes=_fmt(np.concatenate([occ.axis_u, occ.axis_v])),
                material="leaf",
                contype="0",
                conaffinity="0",
            )
        elif isinstance(occ, Stem):
            ET.SubElement(
                world,
                "geom",
                name=f"stem_{i}",
                type="cylinder",
                size=f"{occ.radius:.9g}",
                fromto=_fmt(np.concatenate([occ.start, occ.end])),
                material="stem",
                contype="0",
                conaffinity="0",
            )
        else:  # pragma: no cover - Scene only holds these types
            raise InputError(f"scene.occluders[{i}]: unsupported occluder {type(occ).__name__}")


def check_renderable_camera(camera: Camera) -> Camera:
    """Return ``camera`` if it can be rasterised (no lens distortion), else raise InputError."""
    if not isinstance(camera, Camera):
        raise InputError(f"camera: expected a monovisual3d.Camera, got {type(camera).__name__}")
    if camera.distortion_model != "none":
        raise InputError(
            f"camera.distortion: model {camera.distortion_model!r} cannot be rendered by OpenGL; "
            "render with an undistorted camera (distortion_model='none')"
        )
    return camera


# ---------------------------------------------------------------------- rendering
@dataclass(frozen=True)
class RenderedView:
    """What the camera saw from one pose.

    Attributes
    ----------
    rgb : ndarray, shape (height, width, 3), uint8, RGB
    labels : ndarray, shape (height, width), int32, index of the fruit seen at each pixel, -1 for none
    T_base_optical : ndarray, shape (4, 4)
    """

    rgb: NDArray[np.uint8]
    labels: NDArray[np.int32]
    T_base_optical: NDArray[np.float64]


class MujocoRenderer:
    """Offscreen MuJoCo renderer of one scene seen by one camera.

    Parameters
    ----------
    scene : Scene
    camera : Camera, without distortion; the images have its ``(width, height)``
    config : RenderConfig or None

    Attributes
    ----------
    xml : str, the MJCF model
    model, data : mujoco.MjModel, mujoco.MjData
    geom_fruit : ndarray, shape (ngeom,), int, fruit index of each geom, -1 for other geoms

    Examples
    --------
    >>> from monovisual3d.frames import look_at
    >>> from monovisual3d.sim.scene import Sphere
    >>> scene = Scene((Sphere(np.array([0.5, 0.0, 0.3]), 0.03),))
    >>> with MujocoRenderer(scene, Camera.from_hfov(160, 120, 60.0)) as renderer:  # doctest: +SKIP
    ...     view = renderer.render(look_at([0.0, 0.0, 0.3], [0.5, 0.0, 0.3]))
    >>> view.rgb.shape  # doctest: +SKIP
    (120, 160, 3)
    """

    def __init__(self, scene: Scene, camera: Camera, config: RenderConfig | None = None) -> None:
        self.scene = scene
        self.camera = check_renderable_camera(camera)
        self.config = config or RenderConfig()
        self.xml = mjcf_from_scene(scene, camera, self.config)
        mujoco = _import_mujoco()
        self._mujoco = mujoco
        self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(self.model)
        self._camera_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, "camera")
        self._mocap_id = int(self.model.body_mocapid[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "camera_mount")])
        self.geom_fruit = np.full(self.model.ngeom, -1, dtype=np.int32)
        for i in range(len(scene.fruits)):
            self.geom_fruit[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, f"fruit_{i}")] = i
        try:
            self._renderer = mujoco.Renderer(self.model, camera.height, camera.width)
        except Exception as exc:
            raise RuntimeError(
                f"MuJoCo could not start offscreen rendering with MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r} ({exc}); "
                "set MUJOCO_GL=egl or MUJOCO_GL=osmesa before mujoco is imported"
            ) from exc

    def set_pose(self, T_base_optical: ArrayLike) -> NDArray[np.float64]:
        """Move the camera to ``T_base_optical`` (4, 4) and update the kinematics; returns the checked pose."""
        T = check_transform(T_base_optical, where="T_base_optical")
        position, q_xyzw = position_quaternion_from_transform(T_base_mjcam_from_T_base_optical(T))
        self.data.mocap_pos[self._mocap_id] = position
        self.data.mocap_quat[self._mocap_id] = np.roll(q_xyzw, 1)  # MuJoCo quaternions are (w, x, y, z)
        self._mujoco.mj_forward(self.model, self.data)
        return T

    def _draw(self, segmentation: bool) -> NDArray[Any]:
        r = self._renderer
        if segmentation:
            r.enable_segmentation_rendering()
        else:
            r.disable_segmentation_rendering()
        r.update_scene(self.data, camera=self._camera_id)
        frustum = frustum_from_camera(self.camera, float(r.scene.camera[0].frustum_near))
        for gl_camera in r.scene.camera:
            for name, value in frustum.items():
                setattr(gl_camera, name, value)
        return r.render()

    def render(self, T_base_optical: ArrayLike) -> RenderedView:
        """Render the RGB and label images seen from ``T_base_optical``.

        Parameters
        ----------
        T_base_optical : array_like, shape (4, 4)

        Returns
        -------
        RenderedView
        """
        T = self.set_pose(T_base_optical)
        rgb = np.ascontiguousarray(self._draw(segmentation=False))
        seg = self._draw(segmentation=True)
        is_geom = (seg[..., 1] == int(self._mujoco.mjtObj.mjOBJ_GEOM)) & (seg[..., 0] >= 0)
        labels = np.full(seg.shape[:2], -1, dtype=np.int32)
        labels[is_geom] = self.geom_fruit[seg[..., 0][is_geom]]
        return RenderedView(rgb=rgb, labels=labels, T_base_optical=T)

    def close(self) -> None:
        """Free the OpenGL context."""
        renderer = getattr(self, "_renderer", None)
        if renderer is not None:
            renderer.close()
            self._renderer = None

    def __enter__(self) -> MujocoRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def render_view(scene: Scene, camera: Camera, T_base_optical: ArrayLike, config: RenderConfig | None = None) -> RenderedView:
    """Render one view (builds and frees a :class:`MujocoRenderer`; use the class for many views)."""
    with MujocoRenderer(scene, camera, config) as renderer:
        return renderer.render(T_base_optical)


__all__ = [
    "GL_BACKENDS",
    "MujocoRenderer",
    "RenderConfig",
    "RenderedView",
    "T_base_mjcam_from_T_base_optical",
    "check_renderable_camera",
    "frustum_from_camera",
    "gl_backend_works",
    "mjcf_from_scene",
    "render_view",
    "scene_lowest_z",
    "select_gl_backend",
]
