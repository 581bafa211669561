"""``bench trust``: is the default method ever confidently wrong? Integration mistakes and clean sessions, scored.

For each seed, scene family (:mod:`.trust_cases`: the paper scene, a greenhouse truss, arcs and rows of views)
and box noise level (2, 5, 10 %), a clean session is simulated and localised as ``monovisual3d localize
--strict`` would (:func:`~.trust_runs.run_session`). On one noise level per seed and family, every mistake class
of :data:`monovisual3d.sim.mistakes.MISTAKES` that applies is made on that clean session and localised too.

What is measured (issue 53):

- per mistake class, the share **caught**: refused (exit 2), flagged (``--strict`` exit 1 with a warning), or
  harmless (the clean answer within 3 mm, every fruit's covariance covering its error: NEES under the 95 %
  quantile of chi-square(3), 7.81); the share **named** (a warning or the error contains the words the registry
  gives for the cause: ``hand-eye``, ``time offset``, ``views[N]`` of the view that disagrees, ...); the share whose
  ``quality`` causes hold the cause's ID; the mean error with the mistake, on the clean session and, where the
  method has it, with self-calibration (``calibrate="hand-eye"``; ``import`` with ``time_offset="auto"``);
- the **false-alarm** rate on the clean sessions: any warning, or a verdict that is not ``ok``;
- **NEES** of the fruit paired with the truth, per box noise level: mean (3 when calibrated), share beyond the
  95 % ellipsoid (5 % when calibrated), and covariances missing or not positive definite.

A per-fruit coverage test has a base rate: a calibrated method's K fruit are all inside their 95 % ellipsoids in
``0.95^K`` of sessions (74 % for 6 fruit), so "harmless" needs the answer to be both the clean one and covered.
"""

from __future__ import annotations

import inspect
import json
import zlib
from collections import Counter
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import InputError
from ..io.build import import_session
from ..io.detections import ImageDetections
from ..io.poses import PoseTrajectory
from ..methods import DEFAULT_METHOD, METHODS
from ..sim.mistakes import MISTAKES, Mistaken, applies, make_mistake
from .timing import machine_metadata
from .trust_cases import BOX_NOISES, FAMILIES, TrustCase, make_case
from .trust_runs import NEES_95, RUN_LIMIT_S, clean_record, mean_error_mm, run_session, score_session

#: Default seeds (each runs every family at every noise level, and the mistakes at one level).
DEFAULT_SEEDS = (0, 1)
#: ``--quick``: one seed, two families, one noise level.
QUICK_SEEDS, QUICK_FAMILIES, QUICK_NOISES = (0,), ("paper", "arc"), (0.05,)
#: The issue's targets.
TARGET_CAUGHT, TARGET_NAMED, TARGET_FALSE_ALARM = 0.95, 0.70, 0.10
TARGET_NEES_MEAN, TARGET_NEES_BEYOND = (2.2, 4.0), 0.10
#: Self-calibration: the hand-eye error fixed within this of the error-free run (mm), on this many views and fruit.
TARGET_SELF_CAL_MM, SELF_CAL_MIN_VIEWS, SELF_CAL_MIN_FRUIT = 1.5, 5, 6
#: Distinct messages of the clean sessions listed in the results, most frequent first.
TOP_MESSAGES = 8


def hand_eye_calibration() -> bool:
    """Whether the default method takes ``calibrate`` (``--calibrate hand-eye``)."""
    return "calibrate" in METHODS[DEFAULT_METHOD].config_class.__dataclass_fields__


def time_offset_calibration() -> bool:
    """Whether :func:`~monovisual3d.io.import_session` takes ``time_offset`` (``import --time-offset auto``)."""
    return "time_offset" in inspect.signature(import_session).parameters


def run_trust(
    *,
    seeds: tuple[int, ...] | None = None,
    families: tuple[str, ...] | None = None,
    noises: tuple[float, ...] | None = None,
    mistakes: tuple[str, ...] | None = None,
    quick: bool = False,
    run_limit_s: float | None = RUN_LIMIT_S,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> dict[str, Any]:
    """Run the benchmark; returns a JSON-ready dict (see the module docstring).

    Parameters
    ----------
    seeds, families, noises : default :data:`DEFAULT_SEEDS`, every family, :data:`BOX_NOISES`
        (``quick``: :data:`QUICK_SEEDS`, :data:`QUICK_FAMILIES`, :data:`QUICK_NOISES`)
    mistakes : names of :data:`~monovisual3d.sim.mistakes.MISTAKES` (default all)
    run_limit_s : CPU seconds one session may use before it is stopped and counted as timed out (None: no limit)
    workers, scheduler : spread the cases over Dask (:func:`monovisual3d.batch.spread.spread_map`)
    """
    from ..batch.spread import check_spread, spread_map

    seeds = tuple(seeds) if seeds is not None else (QUICK_SEEDS if quick else DEFAULT_SEEDS)
    families = tuple(families) if families is not None else (QUICK_FAMILIES if quick else FAMILIES)
    noises = tuple(noises) if noises is not None else (QUICK_NOISES if quick else BOX_NOISES)
    mistakes = tuple(mistakes) if mistakes is not None else tuple(MISTAKES)
    _check_choices(seeds, families, noises, mistakes)
    check_spread(workers, scheduler)
    items = [
        (family, seed, sigma, mistakes if sigma == noises[seed % len(noises)] else (), run_limit_s)
        for seed in seeds
        for family in families
        for sigma in noises
    ]

    def tick(i: int, _: Any) -> None:
        if progress is not None:
            progress(f"{items[i][0]} seed {items[i][1]} noise {items[i][2]:g}")

    records = spread_map(measure_case, items, workers=workers, scheduler=scheduler, progress=tick)
    return {
        "benchmark": "trust",
        "quick": quick,
        "machine": machine_metadata(),
        "seeds": list(seeds),
        "families": list(families),
        "noises": list(noises),
        "run_limit_s": run_limit_s,
        "self_calibration": {"hand_eye": hand_eye_calibration(), "time_offset": time_offset_calibration()},
        **summarise(records),
        "cases": records,
    }


def _check_choices(
    seeds: tuple[int, ...], families: tuple[str, ...], noises: tuple[float, ...], mistakes: tuple[str, ...]
) -> None:
    """Refuse unknown families or mistakes, and empty or bad lists, by name."""
    if not seeds or not all(isinstance(s, int) and s >= 0 for s in seeds):
        raise InputError(f"--seeds (seeds): got {list(seeds)}, expected integers >= 0")
    unknown = [f for f in families if f not in FAMILIES]
    if unknown or not families:
        raise InputError(f"--families (families): got {list(families)}, expected some of {list(FAMILIES)}")
    if not noises or not all(0 <= s <= 0.5 for s in noises):
        raise InputError(f"noises: got {list(noises)}, expected box noise levels in [0, 0.5]")
    unknown = [m for m in mistakes if m not in MISTAKES]
    if unknown:
        raise InputError(f"--mistakes (mistakes): got {unknown[0]!r}, expected some of {list(MISTAKES)}")


def measure_case(
    family: str, seed: int, box_sigma: float, mistakes: tuple[str, ...], run_limit_s: float | None = RUN_LIMIT_S
) -> dict[str, Any]:
    """One clean session and the mistakes made on it, each localised and scored (plain JSON values)."""
    case = make_case(family, seed, box_sigma)
    clean = run_session(case.session, limit_s=run_limit_s)
    out: dict[str, Any] = {"case": case.describe(), "clean": clean_record(clean, case.centres, case.radii), "mistakes": {}}
    inputs = case.inputs()
    for name in mistakes:
        mistake = MISTAKES[name]
        if not applies(mistake, inputs):
            continue
        made = make_mistake(name, inputs, mistake_rng(family, seed, name))
        record = score_session(run_session(made.session, limit_s=run_limit_s), clean, case.centres, case.radii, made.words)
        record["details"] = made.details
        record["cause_named_by_id"] = mistake.cause in record["causes"]
        record["clean_error_mm"] = out["clean"]["error_mm"]
        record["self_calibrated"] = _self_calibrated(case, mistake.cause, made, run_limit_s)
        out["mistakes"][name] = record
    return out


def mistake_rng(family: str, seed: int, name: str) -> np.random.Generator:
    """The generator a mistake draws from: one stream per (seed, family, mistake name), whatever else runs."""
    return np.random.default_rng((int(seed), FAMILIES.index(family), zlib.crc32(name.encode())))


def _self_calibrated(case: TrustCase, cause: str, made: Mistaken, limit_s: float | None) -> dict[str, Any] | None:
    """The mistaken session run with the self-calibration of its cause, where the method has one; None otherwise."""
    if cause == "hand_eye" and hand_eye_calibration():
        outcome = run_session(made.session, {"calibrate": "hand-eye"}, limit_s=limit_s)
    elif cause == "time_offset" and time_offset_calibration() and case.frames is not None:
        offset = made.details.get("time_offset_s", made.details.get("frames", 0) / case.frames.frame_rate_hz)
        try:
            imported = import_session(
                case.session.camera, _stream(case, offset), _image_detections(case), match="stamp", time_offset="auto"
            )
        except InputError as exc:
            return {"exit_code": 2, "error": str(exc), "error_mm": None}
        outcome = run_session(imported.session, limit_s=limit_s)
    else:
        return None
    return {
        "exit_code": outcome.exit_code,
        "error": outcome.error,
        "error_mm": mean_error_mm(outcome, case.centres),
        "messages": outcome.messages,
    }


def _stream(case: TrustCase, offset_s: float) -> PoseTrajectory:
    """The case's pose stream running ``offset_s`` ahead of the images (the sample stamped s holds the pose at s + offset)."""
    frames = case.frames
    assert frames is not None
    return PoseTrajectory(frames.stream_T_base_optical, frames.stream_stamps - offset_s, None, "pose stream")


def _image_detections(case: TrustCase) -> list[ImageDetections]:
    """The clean session's boxes per image, with the image stamps (what ``import`` reads from a detections CSV)."""
    return [
        ImageDetections(image=f"view_{i:02d}.png", stamp=v.stamp, detections=v.detections, source="detections")
        for i, v in enumerate(case.session.views)
    ]


# ---------------------------------------------------------------------- summaries
def _share(values: list[bool]) -> float | None:
    return float(np.mean(values)) if values else None


def _mean(values: list[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The tables of the results: ``mistakes`` (per class), ``overall``, ``clean`` (false alarms) and ``nees``."""
    per: dict[str, list[dict[str, Any]]] = {}
    for rec in records:
        for name, r in rec["mistakes"].items():
            per.setdefault(name, []).append({**r, "case": rec["case"]})
    mistakes = {name: _mistake_summary(name, rs) for name, rs in per.items()}
    every = [r for rs in per.values() for r in rs]
    overall = {
        "sessions": len(every),
        "caught": _share([r["caught"] for r in every]),
        "named": _share([r["named"] for r in every]),
        "crashed": sum(r["crashed"] for r in every),
        "timed_out": sum(r["timed_out"] for r in every),
        "not_pd": sum(r["not_pd"] for r in every) + sum(rec["clean"]["not_pd"] for rec in records),
        "cpu_s": sum(r["cpu_s"] for r in every) + sum(rec["clean"]["cpu_s"] for rec in records),
    }
    return {"mistakes": mistakes, "overall": overall, "clean": _clean_summary(records), "nees": _nees_summary(records)}


def _mistake_summary(name: str, rs: list[dict[str, Any]]) -> dict[str, Any]:
    selfcal = [r["self_calibrated"] for r in rs if r["self_calibrated"] is not None]
    eligible = [
        r
        for r in rs
        if r["self_calibrated"] is not None
        and r["case"]["n_views"] >= SELF_CAL_MIN_VIEWS
        and r["case"]["n_fruit"] >= SELF_CAL_MIN_FRUIT
    ]
    return {
        "summary": MISTAKES[name].summary,
        "cause": MISTAKES[name].cause,
        "sessions": len(rs),
        "caught": _share([r["caught"] for r in rs]),
        "refused": _share([r["refused"] for r in rs]),
        "flagged": _share([r["flagged"] for r in rs]),
        "harmless": _share([r["harmless"] for r in rs]),
        "named": _share([r["named"] for r in rs]),
        "cause_id": _share([r["cause_named_by_id"] for r in rs]),
        "crashed": sum(r["crashed"] for r in rs),
        "timed_out": sum(r["timed_out"] for r in rs),
        "not_pd": sum(r["not_pd"] for r in rs),
        "error_mm": _mean([r["error_mm"] for r in rs]),
        "clean_error_mm": _mean([r["clean_error_mm"] for r in rs]),
        "self_calibrated_error_mm": _mean([s["error_mm"] for s in selfcal]) if selfcal else None,
        "self_calibrated_within_target": _share(
            [
                r["self_calibrated"]["error_mm"] is not None
                and r["clean_error_mm"] is not None
                and r["self_calibrated"]["error_mm"] <= r["clean_error_mm"] + TARGET_SELF_CAL_MM
                for r in eligible
            ]
        ),
        "max_runtime_s": max(r["runtime_s"] for r in rs),
        "max_cpu_s": max(r["cpu_s"] for r in rs),
    }


def _clean_summary(records: list[dict[str, Any]]) -> dict[str, Any]:
    by_family: dict[str, list[dict[str, Any]]] = {}
    for rec in records:
        by_family.setdefault(rec["case"]["family"], []).append(rec["clean"])
    messages = Counter(m[:200] for rec in records for m in rec["clean"]["messages"])
    alarms = [rec["clean"]["alarm"] for rec in records]
    return {
        "sessions": len(alarms),
        "false_alarm": _share(alarms),
        "by_family": {
            f: {"sessions": len(v), "false_alarm": _share([c["alarm"] for c in v]), "timed_out": sum(c["timed_out"] for c in v)}
            for f, v in by_family.items()
        },
        "error_mm": _mean([rec["clean"]["error_mm"] for rec in records]),
        "timed_out": sum(rec["clean"]["timed_out"] for rec in records),
        "max_runtime_s": max(rec["clean"]["runtime_s"] for rec in records) if records else None,
        "max_cpu_s": max(rec["clean"]["cpu_s"] for rec in records) if records else None,
        "top_messages": [{"message": m, "count": c} for m, c in messages.most_common(TOP_MESSAGES)],
    }


def _nees_summary(records: list[dict[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for sigma in sorted({rec["case"]["box_sigma"] for rec in records}):
        recs = [rec["clean"] for rec in records if rec["case"]["box_sigma"] == sigma]
        values = [v for r in recs for v in r["nees"]]
        valid = np.array([v for v in values if v is not None])
        out[f"{sigma:g}"] = {
            "fruit": len(values),
            "mean": float(valid.mean()) if len(valid) else None,
            "beyond_95": float(np.mean(valid > NEES_95)) if len(valid) else None,
            "without_covariance": sum(v is None for v in values),
            "not_pd": sum(r["not_pd"] for r in recs),
        }
    return out


def check_targets(results: dict[str, Any]) -> list[tuple[str, float | None, str, bool]]:
    """(what, measured, target, met) for the issue's targets that the results measure."""
    o, c = results["overall"], results["clean"]
    rows = [
        (
            "mistaken sessions caught",
            o["caught"],
            f">= {TARGET_CAUGHT:g}",
            o["caught"] is not None and o["caught"] >= TARGET_CAUGHT,
        ),
        ("mistaken sessions named", o["named"], f">= {TARGET_NAMED:g}", o["named"] is not None and o["named"] >= TARGET_NAMED),
        (
            "clean sessions with an alarm",
            c["false_alarm"],
            f"<= {TARGET_FALSE_ALARM:g}",
            c["false_alarm"] is not None and c["false_alarm"] <= TARGET_FALSE_ALARM,
        ),
        ("covariances not positive definite", float(o["not_pd"]), "= 0", o["not_pd"] == 0),
    ]
    lo, hi = TARGET_NEES_MEAN
    for sigma, n in results["nees"].items():
        mean, beyond = n["mean"], n["beyond_95"]
        rows.append((f"mean NEES, {sigma} box noise", mean, f"{lo:g}-{hi:g}", mean is not None and lo <= mean <= hi))
        rows.append(
            (
                f"share beyond 95 %, {sigma} box noise",
                beyond,
                f"<= {TARGET_NEES_BEYOND:g}",
                beyond is not None and beyond <= TARGET_NEES_BEYOND,
            )
        )
    return rows


def format_markdown(results: dict[str, Any]) -> str:
    """The benchmark's tables (Markdown): per mistake class, clean sessions, NEES, the targets."""
    m = results["machine"]
    sc = results["self_calibration"]
    lines = [
        f"Machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}; {m['date_utc'][:10]}, "
        f"load average {m.get('load_average_1m', float('nan')):.1f}; seeds {results['seeds']}, families "
        f"{', '.join(results['families'])}, box noise {', '.join(f'{s:g}' for s in results['noises'])}"
        + (" (quick mode)" if results["quick"] else ""),
        "",
        "| mistake | cause | sessions | caught | refused | flagged | harmless | named | cause ID | error mm | clean mm "
        "| self-calibrated mm | slowest CPU s | timed out |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, r in results["mistakes"].items():
        lines.append(
            f"| {name} | {r['cause']} | {r['sessions']} | {_pct(r['caught'])} | {_pct(r['refused'])} | {_pct(r['flagged'])} | "
            f"{_pct(r['harmless'])} | {_pct(r['named'])} | {_pct(r['cause_id'])} | {_num(r['error_mm'])} | "
            f"{_num(r['clean_error_mm'])} | {_num(r['self_calibrated_error_mm'])} | {_num(r['max_cpu_s'])} | {r['timed_out']} |"
        )
    o = results["overall"]
    lines.append(f"| **all** | | {o['sessions']} | {_pct(o['caught'])} | | | | {_pct(o['named'])} | | | | | | {o['timed_out']} |")
    lines.append("")
    lines.append(
        "Self-calibration: hand-eye (calibrate='hand-eye') "
        + ("run" if sc["hand_eye"] else "not in the method yet")
        + "; time offset (import time_offset='auto') "
        + ("run" if sc["time_offset"] else "not in import yet")
        + f". Sessions that crashed (not InputError): {o['crashed']}; stopped after {results['run_limit_s']} CPU seconds (not caught): "
        f"{o['timed_out']}."
    )
    c = results["clean"]
    lines += ["", "| clean sessions | sessions | with an alarm | timed out |", "|---|---:|---:|---:|"]
    lines += [f"| {f} | {v['sessions']} | {_pct(v['false_alarm'])} | {v['timed_out']} |" for f, v in c["by_family"].items()]
    lines.append(f"| **all** | {c['sessions']} | {_pct(c['false_alarm'])} | {c['timed_out']} |")
    lines.append(f"\nCPU time of all the sessions: {o['cpu_s']:.0f} s; slowest clean session {_num(c['max_cpu_s'])} CPU s.")
    lines += ["", "| box noise | fruit | mean NEES | beyond 95 % | no covariance | not PD |", "|---:|---:|---:|---:|---:|---:|"]
    for sigma, n in results["nees"].items():
        lines.append(
            f"| {sigma} | {n['fruit']} | {_num(n['mean'])} | {_pct(n['beyond_95'])} | {n['without_covariance']} | {n['not_pd']} |"
        )
    lines += ["", "| target | measured | target | met |", "|---|---:|---:|:---:|"]
    for what, value, target, met in check_targets(results):
        lines.append(f"| {what} | {_num(value, 3)} | {target} | {'yes' if met else 'NO'} |")
    if c["top_messages"]:
        lines += ["", "Most frequent messages on clean sessions:", ""]
        lines += [f"- {t['count']} x {t['message']}" for t in c["top_messages"]]
    return "\n".join(lines) + "\n"


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.0f} %"


def _num(v: float | None, digits: int = 1) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{v:.{digits}f}"


def save(results: dict[str, Any], path: str) -> None:
    with open(path, "w") as fh:
        json.dump(results, fh, indent=2)
