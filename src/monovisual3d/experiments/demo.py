"""The demo: simulate a greenhouse tomato truss, localise the fruit, evaluate, save files and a figure.

This is what ``monovisual3d demo`` runs; the CLI only prints the outcome.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..api import DEFAULT_METHOD, METHODS, localize
from ..camera import Camera
from ..checks import is_int
from ..errors import InputError, InputWarning
from ..figures.views import write_view_picture
from ..metrics import Metrics, evaluate
from ..result import Result
from ..session import Session
from ..session.load import load_session
from ..sim.noise import NoiseModel
from ..sim.scene import Scene
from ..sim.scenes import default_camera, greenhouse_scene, scene_target
from ..sim.simulate import write_simulation
from ..sim.viewpoints import paper_poses

#: Default output directory of the demo.
DEFAULT_OUTPUT = Path("mv3d-demo")
#: The README's figure for the demo's setting, per method: mean error (mm) pooled over every matched fruit of
#: seeds 0..19 of ``monovisual3d bench accuracy``, condition ``greenhouse-noise`` (same truss generator, poses and
#: noise as the demo). One seed's error scatters around it; a test keeps these equal to the README's row.
README_MEAN_ERROR_MM = {"bayes": 5.44, "paper": 145.0}
#: Seeds behind :data:`README_MEAN_ERROR_MM`.
README_SEEDS = "0..19"


def compare_with_readme(metrics: Metrics, seed: int, method: str) -> str:
    """One sentence putting this seed's mean error beside the README's multi-seed mean for the same setting.

    Examples
    --------
    >>> from monovisual3d.metrics import evaluate
    >>> m = evaluate([[0.0, 0.0, 0.0075]], [[0.0, 0.0, 0.0]])
    >>> compare_with_readme(m, 0, "bayes")  # doctest: +NORMALIZE_WHITESPACE
    "mean error 7.5 mm on this seed (0); the README's 5.44 mm is the mean over all fruit of seeds 0..19 of
    `monovisual3d bench accuracy`, condition greenhouse-noise (the demo's setting)"
    """
    here = f"mean error {1e3 * metrics.euclidean_mean:.1f} mm on this seed ({seed})"
    ref = README_MEAN_ERROR_MM.get(method)
    if ref is None:
        return here
    return (
        f"{here}; the README's {ref:g} mm is the mean over all fruit of seeds {README_SEEDS} of "
        "`monovisual3d bench accuracy`, condition greenhouse-noise (the demo's setting)"
    )


@dataclass
class DemoResult:
    """Everything the demo produced.

    Attributes
    ----------
    scene : Scene, the simulated truss (ground truth)
    session : Session, what the robot recorded (noisy boxes at the three poses)
    result : Result, the localised fruit
    metrics : Metrics, ``result`` evaluated against the scene
    files : dict name -> path of the written files
    noise : NoiseModel, the detector noise used
    seconds : dict stage -> seconds
    notes : list of str, e.g. why the figure was skipped
    """

    scene: Scene
    session: Session
    result: Result
    metrics: Metrics
    files: dict[str, Path]
    noise: NoiseModel
    seconds: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def check_demo_options(output: str | Path = DEFAULT_OUTPUT, *, seed: int = 0, method: str = DEFAULT_METHOD) -> Path:
    """Validate the demo's options before anything is printed or written; returns the output folder.

    Raises
    ------
    InputError
        Naming the option (``--method (method): got 'foo', ...``).

    Examples
    --------
    >>> check_demo_options("mv3d-demo", seed=1, method="paper").name
    'mv3d-demo'
    """
    if method not in METHODS:
        raise InputError(f"--method (method): got {method!r}, expected one of {sorted(METHODS)}")
    if not is_int(seed) or seed < 0:
        raise InputError(f"--seed (seed): got {seed!r}, expected an integer >= 0")
    out = Path(output)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: --output (output): exists and is not a directory")
    return out


def run_demo(
    output: str | Path = DEFAULT_OUTPUT,
    *,
    seed: int = 0,
    method: str = DEFAULT_METHOD,
    noise: NoiseModel | None = None,
    figure: bool = True,
    **options: Any,
) -> DemoResult:
    """Simulate, localise, evaluate and write ``session.json``, ``truth.json``, ``result.json`` and ``scene.png``.

    The scene is :func:`~monovisual3d.sim.scenes.greenhouse_scene` (5-10 tomatoes of 2-4 cm
    radius on a truss, leaves partly hiding some), seen from the paper's three poses by the
    default 640 x 480 camera, with the paper's detector noise (5 % box noise, 2 % missed
    detections) unless ``noise`` says otherwise.

    Parameters
    ----------
    output : directory for the files (created if needed)
    seed : int, seeds the scene and the noise
    method : str, a localisation method (default: the library's default, ``bayes``)
    noise : NoiseModel, default :meth:`NoiseModel.paper`
    figure : bool, write ``scene.png`` (needs matplotlib, extra ``[viz]``; skipped with a note without it)
    **options : passed to :func:`monovisual3d.localize`

    Returns
    -------
    DemoResult

    Examples
    --------
    >>> import tempfile
    >>> d = run_demo(tempfile.mkdtemp(), figure=False)  # doctest: +SKIP
    >>> d.metrics.recall  # doctest: +SKIP
    1.0
    """
    out = check_demo_options(output, seed=seed, method=method)
    noise = NoiseModel.paper() if noise is None else noise
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    sim = _simulate(out, seed, noise)
    t1 = time.perf_counter()
    seconds["simulate"] = t1 - t0
    session = load_session(sim.files["session"])
    result = _localise(session, method, options)
    t2 = time.perf_counter()
    seconds["localise"] = t2 - t1
    files: dict[str, Path] = dict(sim.files)
    files["result"] = out / "result.json"
    result.to_json(files["result"])
    metrics = _evaluate(result, sim.scene)
    notes = _write_figures(files, out, seed, sim, session, result) if figure else []
    seconds["evaluate_and_figure"] = time.perf_counter() - t2
    seconds["total"] = time.perf_counter() - t0
    return DemoResult(sim.scene, session, result, metrics, files, noise, seconds, notes)


@dataclass(frozen=True)
class _Simulation:
    """What the simulation stage made: the truss, the camera, its poses and the files written."""

    scene: Scene
    camera: Camera
    #: shape (3, 4, 4), ``T_base_optical`` of the paper's three poses
    poses: NDArray[np.float64]
    files: dict[str, Path]


def _simulate(out: Path, seed: int, noise: NoiseModel) -> _Simulation:
    """Simulate the truss of ``seed`` from the paper's poses; write session, truth, images and view picture to ``out``."""
    rng = np.random.default_rng(seed)
    camera = default_camera()
    scene = greenhouse_scene(rng, camera=camera)
    poses = paper_poses(scene_target(scene))
    paths = write_simulation(out, scene, camera, poses, noise=noise, rng=rng, images=True, picture=write_view_picture)
    return _Simulation(scene, camera, poses, dict(paths))


def _localise(session: Session, method: str, options: dict[str, Any]) -> Result:
    """Localise with ``method``; input warnings raised on the way are kept in the result's warnings (once each)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        result = localize(session, method=method, **options)
    result.warnings.extend(str(w.message) for w in caught if str(w.message) not in result.warnings)
    return result


def _evaluate(result: Result, scene: Scene) -> Metrics:
    """The result against the scene's truth; radius errors only when the method estimated some radius."""
    radii = [np.nan if o.radius is None else o.radius for o in result.objects]
    return evaluate(
        result.positions, scene.centres, truth_radii=scene.radii, estimate_radii=radii if any(np.isfinite(radii)) else None
    )


def _write_figures(files: dict[str, Path], out: Path, seed: int, sim: _Simulation, session: Session, result: Result) -> list[str]:
    """Write ``scene.png`` and ``scene.html`` into ``out`` and add them to ``files``; returns a note per figure skipped."""
    notes: list[str] = []
    try:
        files["figure"] = _scene_figure(out / "scene.png", seed, sim.scene, result, sim.camera, sim.poses)
    except ImportError as exc:
        notes.append(f"figure skipped: {exc}")
    try:
        from ..figures.html3d import write_scene_html

        files["scene_html"] = write_scene_html(session, result, sim.scene.truth_dict(), path=out / "scene.html")
    except ImportError as exc:
        notes.append(f"scene.html skipped: {exc}")
    return notes


def _scene_figure(path: Path, seed: int, scene: Scene, result: Result, camera: Camera, poses: NDArray[np.float64]) -> Path:
    """Draw the scene's truth, the estimates and the cameras (``poses``: ``T_base_optical``, shape (N, 4, 4)) into ``path``.

    Raises ImportError without matplotlib (extra ``[viz]``).
    """
    from ..figures import plot_scene, save_figure

    fig = plot_scene(
        scene.centres,
        scene.radii,
        estimates=result.positions,
        estimate_radii=[o.radius for o in result.objects],
        camera=camera,
        poses=poses,
        occluders=scene.occluders,
        title=f"greenhouse truss (seed {seed}): {len(scene.fruits)} true fruit (green), "
        f"{len(result.objects)} found by '{result.method}' (red)",
    )
    return save_figure(fig, path)
