"""A/B of ``localize`` options: the default against the same code with some options changed, side by side.

``monovisual3d bench ab time`` and ``bench ab accuracy`` run these; experiments take their ``localize`` options from
the command line with :func:`split_options` (``script.py ARGS -- KEY=VALUE ...``).

- :func:`parse_options`: ``KEY=VALUE`` texts to ``localize`` options, values read as JSON where they parse
  (``radius_max=0.08``, ``size_range=[0.01,0.15]``, ``solids=false``), else kept as text (``shape=auto``).
- :func:`time_options`: each variant's median ``localize`` time, alternated in one process after a warm-up of each, on
  the paper scene (6 fruit, 3 views, the paper's box noise, one fixed draw) and on six fruit of mixed shapes (five draws): a
  change's cost measured at one moment of a shared machine, whose speed drifts by tens of per cent between minutes.
- :func:`accuracy_options`: a condition of ``bench accuracy`` (its scenes, noise, matching and options) on chosen
  seeds with each variant: mean, RMS, median and max centre error of the matched fruit, recall and precision.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..errors import InputError
from ..metrics import evaluate, match
from ..sim.noise import NoiseModel
from ..sim.scenes import paper_scene, shapes_scene
from ..sim.simulate import simulate
from .accuracy import conditions, simulated_session

#: The paper scene's noise seed and the mixed-shapes seeds of :func:`time_options`.
PAPER_SEED = 3
MIXED_SEEDS = tuple(range(5))
#: Timed rounds of :func:`time_options` (each round runs every variant on every scene once).
DEFAULT_ROUNDS = 5
#: The name of the variant without changed options.
DEFAULT = "default"


def option_value(text: str) -> Any:
    """A ``KEY=VALUE`` option's value: a JSON number, list, boolean or null where it parses as one, else the text.

    Examples
    --------
    >>> option_value("0.08"), option_value("[0.02,0.15]"), option_value("false"), option_value("auto")
    (0.08, [0.02, 0.15], False, 'auto')
    """
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def parse_options(pairs: Sequence[str]) -> dict[str, Any]:
    """``localize`` options from ``KEY=VALUE`` texts (values by :func:`option_value`).

    Examples
    --------
    >>> parse_options(["radius_max=0.08", "shape=auto"])
    {'radius_max': 0.08, 'shape': 'auto'}
    """
    bad = [p for p in pairs if "=" not in p or not p.split("=", 1)[0]]
    if bad:
        raise InputError(f"options: got {bad}, expected KEY=VALUE (e.g. radius_max=0.08 or size_range=[0.01,0.15])")
    return {k: option_value(v) for k, v in (p.split("=", 1) for p in pairs)}


def split_options(argv: Sequence[str]) -> tuple[list[str], dict[str, Any]]:
    """An experiment's own arguments (before ``--``) and the ``localize`` options after it (:func:`parse_options`).

    Examples
    --------
    >>> split_options(["810", "813", "--", "second_look=false"])
    (['810', '813'], {'second_look': False})
    >>> split_options(["810", "813"])
    (['810', '813'], {})
    """
    argv = list(argv)
    if "--" not in argv:
        return argv, {}
    i = argv.index("--")
    return argv[:i], parse_options(argv[i + 1 :])


def variants(pairs: Sequence[str]) -> dict[str, dict[str, Any]]:
    """The variants of an A/B: :data:`DEFAULT` (no options) and, unless ``pairs`` is empty, the options of ``pairs``
    (``KEY=VALUE`` texts), named by their text.

    Examples
    --------
    >>> variants(["regroup=false"])
    {'default': {}, 'regroup=false': {'regroup': False}}
    >>> variants([])
    {'default': {}}
    """
    return {DEFAULT: {}, " ".join(pairs): parse_options(pairs)} if pairs else {DEFAULT: {}}


def _timing_scenes(mixed_seeds: Sequence[int]) -> dict[str, list[Any]]:
    """The sessions of :func:`time_options`: the noisy paper scene, and six fruit of mixed shapes per seed."""
    return {
        "paper scene": [simulate(paper_scene(), noise=NoiseModel.paper(), rng=PAPER_SEED)[0]],
        "mixed shapes": [simulated_session(shapes_scene("mixed", rng=s), NoiseModel(), s, masks=False)[0] for s in mixed_seeds],
    }


def time_options(
    variant_options: dict[str, dict[str, Any]],
    rounds: int = DEFAULT_ROUNDS,
    mixed_seeds: Sequence[int] = MIXED_SEEDS,
    progress: Callable[[str], None] | None = None,
) -> dict[str, dict[str, float]]:
    """Median ``localize`` time (seconds) per variant and scene, the variants alternated in one process.

    Parameters
    ----------
    variant_options : dict, variant name -> ``localize`` options (:func:`variants`)
    rounds : int, timed rounds after one untimed call of each variant on each session
    mixed_seeds : sequence of int, seeds of the mixed-shapes scenes
    progress : callable or None, called with a short text before each round

    Returns
    -------
    dict
        variant -> scene name -> median seconds of one call
    """
    from ..api import localize

    if not (isinstance(rounds, int) and rounds >= 1):
        raise InputError(f"rounds: got {rounds!r}, expected an integer >= 1")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scenes = _timing_scenes(mixed_seeds)
        for sessions in scenes.values():
            for s in sessions:
                for opts in variant_options.values():
                    localize(s, **opts)
        times: dict[tuple[str, str], list[float]] = {(v, n): [] for v in variant_options for n in scenes}
        for r in range(rounds):
            if progress is not None:
                progress(f"round {r + 1} of {rounds}")
            for v, opts in variant_options.items():
                for n, sessions in scenes.items():
                    for s in sessions:
                        t0 = time.perf_counter()
                        localize(s, **opts)
                        times[v, n].append(time.perf_counter() - t0)
    return {v: {n: float(np.median(times[v, n])) for n in scenes} for v in variant_options}


def accuracy_options(
    condition: str, seeds: Sequence[int], variant_options: dict[str, dict[str, Any]]
) -> dict[str, dict[str, float]]:
    """Centre errors, recall and precision of each variant on one ``bench accuracy`` condition over ``seeds``.

    Each variant's options go over the condition's own options of ``bayes``. The errors are those of the matched
    fruit (Hungarian, however far apart); recall and precision count the pairs within the gate of
    :func:`monovisual3d.metrics.evaluate` (the fruit's radius).

    Returns
    -------
    dict
        variant -> ``mean_mm``, ``rms_mm``, ``median_mm``, ``max_mm``, ``recall``, ``precision``
    """
    from ..api import localize

    cond = next((c for c in conditions() if c.name == condition), None)
    if cond is None:
        raise InputError(f"condition: got {condition!r}, expected one of {[c.name for c in conditions()]}")
    if not len(seeds):
        raise InputError("seeds: none given, expected at least one seed")
    stats: dict[str, dict[str, Any]] = {v: {"err": [], "tp": 0, "truth": 0, "est": 0} for v in variant_options}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in seeds:
            scene = cond.scene(seed)
            session, _ = simulated_session(scene, cond.noise, seed, masks=False)
            for v, opts in variant_options.items():
                est = localize(session, **{**cond.method_options("bayes"), **opts}).positions
                m = evaluate(est, scene.centres, truth_radii=scene.radii)
                ei, ti = match(est, scene.centres)
                stats[v]["err"] += np.linalg.norm(est[ei] - scene.centres[ti], axis=1).tolist()
                stats[v]["tp"] += m.true_positives
                stats[v]["truth"] += m.n_truth
                stats[v]["est"] += m.n_estimates
    return {v: _error_summary(s) for v, s in stats.items()}


def _error_summary(s: dict[str, Any]) -> dict[str, float]:
    e = np.array(s["err"]) * 1e3
    return {
        "mean_mm": float(e.mean()) if len(e) else float("nan"),
        "rms_mm": float(np.sqrt(np.mean(e**2))) if len(e) else float("nan"),
        "median_mm": float(np.median(e)) if len(e) else float("nan"),
        "max_mm": float(e.max()) if len(e) else float("nan"),
        "recall": s["tp"] / s["truth"] if s["truth"] else float("nan"),
        "precision": s["tp"] / max(s["est"], 1),
    }


def format_time(result: dict[str, dict[str, float]]) -> list[str]:
    """One line per variant: its median time (ms) per scene."""
    return [f"{v}: " + ", ".join(f"{n} {1e3 * t:.0f} ms" for n, t in scenes.items()) for v, scenes in result.items()]


def format_accuracy(condition: str, seeds: Sequence[int], result: dict[str, dict[str, float]]) -> list[str]:
    """One line per variant: mean, RMS, median and max error (mm), recall and precision."""
    where = f"{condition} seeds {seeds[0]}-{seeds[-1]}"
    return [
        f"{where}, {v}: mean {r['mean_mm']:.2f} rms {r['rms_mm']:.2f} median {r['median_mm']:.2f} max {r['max_mm']:.1f} mm, "
        f"recall {r['recall']:.3f}, precision {r['precision']:.3f}"
        for v, r in result.items()
    ]
