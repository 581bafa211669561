"""Run fuzz cases and judge them with the oracle of issue 13.

Oracle, per case:

- the outcome is success or an :class:`~monovisual3d.errors.InputError` (CLI: exit 0 or 2), never another exception;
- the case ends within :data:`CASE_TIMEOUT_S` (a SIGALRM timer; longer counts as a hang);
- a session accepted by ``load_session`` (exit 0) is accepted by the published JSON Schema;
- no result, metric or written file holds a non-finite number;
- an error is one line of at most :data:`MAX_ERROR_CHARS` characters that starts with the file's name.

Peak memory is the process's maximum resident set size (``getrusage``), read after
every case, so the case that raised it is known.

Run from the repository root, e.g. ``PYTHONPATH=src python tests/fuzz/runner.py --cases 10000 --seed 13``.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import resource
import shutil
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import bounds  # noqa: E402
import mutate  # noqa: E402

from monovisual3d import InputError, load_session, localize  # noqa: E402
from monovisual3d._structured import read_structured_file  # noqa: E402
from monovisual3d.io.schema import session_schema  # noqa: E402
from monovisual3d.metrics import evaluate  # noqa: E402
from monovisual3d.truth import load_objects  # noqa: E402

#: A case running longer than this (seconds) is a hang. Generous: the machine is shared and noisy.
CASE_TIMEOUT_S = 30.0
#: Longest accepted error line.
MAX_ERROR_CHARS = 300
FIXTURES = Path(__file__).parent.parent / "io" / "fixtures"
IMPORT_BASES = [
    ("ros_camera_info.yaml", "poses.csv", "detections.csv"),
    ("ros_camera_info.yaml", "poses.csv", "coco_annotations.json"),
    ("opencv_calibration.yaml", "poses.csv", "yolo_labels"),
    ("depthai_oak1.json", "poses.csv", "yolo_labels"),
]
#: Options that keep ``localize`` cheap (milliseconds to tenths of a second per case).
PAPER_FAST = {"resolution": 0.05, "reach": 0.3, "max_memory": 2**26}
BAYES_FAST: dict[str, Any] = {}
SMALL_WORKSPACE = {"min": [0.45, -0.15, 0.3], "max": [0.75, 0.15, 0.6]}


_VALIDATOR: Any = None


def validate_session_schema(data: Any) -> list[str]:
    """Schema errors of ``data`` (one compiled validator for the whole run)."""
    global _VALIDATOR
    if _VALIDATOR is None:
        import jsonschema

        _VALIDATOR = jsonschema.Draft202012Validator(session_schema())
    return [f"{list(e.absolute_path)}: {e.message}" for e in _VALIDATOR.iter_errors(data)]


class Hang(Exception):
    pass


def _alarm(signum: int, frame: Any) -> None:
    raise Hang


@dataclass
class Report:
    seed: int
    counts: Counter[str] = field(default_factory=Counter)
    failures: list[dict[str, Any]] = field(default_factory=list)
    longest_error: str = ""
    slowest: tuple[float, str] = (0.0, "")
    peak_rss_mib: float = 0.0
    peak_case: str = ""
    wall_s: float = 0.0
    times: Counter[str] = field(default_factory=Counter)
    cpu_s: float = 0.0
    log: Any = None

    def fail(self, case: str, kind: str, detail: str) -> None:
        self.counts[f"fail:{kind}"] += 1
        if self.log is not None:
            print(f"FAIL {case} {kind}: {detail[-1500:]}", file=self.log, flush=True)
        if len(self.failures) < 200:
            self.failures.append({"case": case, "kind": kind, "detail": detail[-2000:]})

    def summary(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "counts": dict(sorted(self.counts.items())),
            "failures": self.failures[:20],
            "longest_error_chars": len(self.longest_error),
            "longest_error": self.longest_error,
            "slowest_case_s": round(self.slowest[0], 3),
            "slowest_case": self.slowest[1],
            "peak_rss_mib": round(self.peak_rss_mib, 1),
            "peak_case": self.peak_case,
            "wall_s": round(self.wall_s, 1),
            "cpu_s": round(self.cpu_s, 1),
            "seconds_by_kind": {k: round(v, 1) for k, v in sorted(self.times.items())},
        }


def _finite_tree(value: Any) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, np.ndarray):
        return value.dtype.kind not in "fc" or bool(np.all(np.isfinite(value)))
    if isinstance(value, dict):
        return all(_finite_tree(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return all(_finite_tree(v) for v in value)
    return True


def _check_error(report: Report, case: str, message: str, source: str | tuple[str, ...] | None) -> None:
    report.counts["input_error"] += 1
    if len(message) > len(report.longest_error):
        report.longest_error = message
    if "\n" in message or "\r" in message or not message.isprintable():
        report.fail(case, "multiline", message[:400])
    if len(message) > MAX_ERROR_CHARS:
        report.fail(case, "long_error", message[:400])
    sources = (source,) if isinstance(source, str) else source
    if sources and not any(message.startswith(f"{s}: ") for s in sources):
        report.fail(case, "no_file_name", message[:400])


def _check_result(report: Report, case: str, result: Any) -> None:
    """Positions, scores and radii must be finite; a NaN covariance marks an undetermined object (counted apart)."""
    d = result.to_dict()
    core = [[o.get(k) for k in ("position", "score", "radius")] for o in d["objects"]]
    rest = {k: v for k, v in d.items() if k != "objects"}
    if not _finite_tree(core) or not _finite_tree(rest):
        report.fail(case, "non_finite", json.dumps(d, default=str)[:400])
    elif not _finite_tree(d):
        report.counts["nan_covariance"] += 1
    report.counts["localized"] += 1


# ---------------------------------------------------------------------- case kinds
def session_case(rng: random.Random, tmp: Path, report: Report, case: str, bases: list[dict[str, Any]]) -> None:
    """Mutated session through load_session (file or dict), then localize with a cheap configuration."""
    data = mutate.mutate_session(rng.choice(bases), rng)
    source: str | None = None
    if rng.random() < 0.75:
        raw, suffix = mutate.to_text(data, rng)
        path = tmp / f"s{suffix}"
        path.write_bytes(raw)
        source = str(path)
        inp: Any = path
    else:
        inp = data
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            session = load_session(inp)
    except InputError as exc:
        _check_error(report, case, str(exc), source)
        return
    report.counts["loaded"] += 1
    parsed = read_structured_file(inp) if source else data
    problems = validate_session_schema(parsed)
    if problems:
        report.fail(case, "schema", f"loader accepted, schema refused: {problems[0][:300]}")
    small_session = len(session.views) <= 20 and all(len(v.detections) <= 20 for v in session.views)
    if small_session and rng.random() < LOCALIZE_SHARE:
        method = rng.choice(["paper", "bayes"])
        ws = session.workspace
        small = ws is None or float(np.max(ws.max - ws.min)) <= 1.0  # a bigger dense grid is slow by design
        opts = dict(PAPER_FAST if method == "paper" else BAYES_FAST)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = localize(session, method=method, workspace=None if small else SMALL_WORKSPACE, **opts)
        except InputError as exc:
            msg = str(exc)
            _check_error(report, case, msg if not source else f"{source}: {msg}", source)
            return
        _check_result(report, case, result)


def evaluate_case(rng: random.Random, tmp: Path, report: Report, case: str) -> None:
    """Mutated truth/estimate files through load_objects and evaluate."""
    bases = mutate.base_objects()
    paths = []
    for name in ("e", "t"):
        data = mutate.mutate_tree(rng.choice(bases), rng) if rng.random() < 0.7 else rng.choice(bases)
        raw, suffix = mutate.to_text(data, rng)
        p = tmp / f"{name}{suffix}"
        p.write_bytes(raw)
        paths.append(p)
    try:
        est = load_objects(paths[0])
        tru = load_objects(paths[1], allow_empty=False)
    except InputError as exc:
        msg = str(exc)
        _check_error(report, case, msg, str(paths[0]) if msg.startswith(str(paths[0])) else str(paths[1]))
        return
    m = evaluate(est.positions, tru.positions, truth_radii=tru.radii if tru.has_radii else None, estimate_radii=est.radii)
    d = m.to_dict()
    undefined = {"precision", "recall", "mape", "euclidean_mean", "euclidean_median", "euclidean_max", "mae", "mse", "rmse"}
    bad = [k for k, v in d.items() if isinstance(v, float) and not math.isfinite(v) and not (math.isnan(v) and k in undefined)]
    if bad:
        report.fail(case, "non_finite", f"metrics {bad}: {d}")
    report.counts["evaluated"] += 1


def import_case(rng: random.Random, tmp: Path, report: Report, case: str) -> None:
    """Mutated calibration / pose / detection fixtures through import_session."""
    from monovisual3d.io import import_session

    names = rng.choice(IMPORT_BASES)
    paths = []
    for name in names:
        src = FIXTURES / name
        dst = tmp / name
        if src.is_dir():
            shutil.copytree(src, dst, dirs_exist_ok=True)
        else:
            shutil.copy(src, dst)
        paths.append(dst)
    target = rng.randrange(3)
    victim = paths[target]
    if victim.is_dir():
        files = sorted(victim.glob("*.txt"))
        victim = rng.choice(files)
    mutate.mutate_text_file(victim, rng)
    hand_eye = FIXTURES / "hand_eye_opencv.json" if rng.random() < 0.2 else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = import_session(*paths, hand_eye=hand_eye)
    except InputError as exc:
        _check_error(report, case, str(exc), None)
        return
    d = result.session.to_dict()
    if not _finite_tree(d):
        report.fail(case, "non_finite", json.dumps(d, default=str)[:400])
    problems = validate_session_schema(json.loads(json.dumps(d)))
    if problems:
        report.fail(case, "schema", f"import wrote a session the schema refuses: {problems[0][:300]}")
    report.counts["imported"] += 1


def cli_case(rng: random.Random, tmp: Path, report: Report, case: str, bases: list[dict[str, Any]]) -> None:
    """The real CLI (in-process through Typer's runner): localize, evaluate or import, with output files."""
    from typer.testing import CliRunner

    from monovisual3d.cli import app

    kind = rng.choice(["localize", "localize", "evaluate", "import"])
    out = tmp / "out.json"
    if kind == "localize":
        data = mutate.mutate_session(rng.choice(bases), rng) if rng.random() < 0.8 else rng.choice(bases)
        raw, suffix = mutate.to_text(data, rng)
        path = tmp / f"s{suffix}"
        path.write_bytes(raw)
        method = rng.choice(["paper", "bayes"])
        opts = ["--method", "paper", "--resolution", "0.05", "--reach", "0.3"] if method == "paper" else ["--method", "bayes"]
        hostile_opt = rng.random()
        if hostile_opt < 0.15:
            opts += rng.choice(
                [
                    ["--k", "²"],
                    ["--k", "0"],
                    ["--k", "99999999999999999999"],
                    ["--resolution", "nan"],
                    ["--resolution", "1e-300"],
                    ["--reach", "1e5"],
                    ["--reach", "inf"],
                    ["--accept", "nan"],
                    ["--pose-sigma-mm", "-1"],
                    ["--kernel", "\x1b[31m"],
                ]
            )
        target = rng.choice([str(out), str(out), "/dev/full", str(path), str(tmp / "nodir" / "x.json"), str(tmp)])
        args = ["localize", str(path), "-q", *opts, "-o", target]
        # a big workspace would make a dense grid: the grid guard is fuzzed in-process; keep the CLI cheap
        source = str(path)
    elif kind == "evaluate":
        paths = []
        for name in ("e", "t"):
            data = mutate.mutate_tree(rng.choice(mutate.base_objects()), rng) if rng.random() < 0.6 else mutate.base_objects()[0]
            raw, suffix = mutate.to_text(data, rng)
            p = tmp / f"{name}{suffix}"
            p.write_bytes(raw)
            paths.append(str(p))
        target = rng.choice([str(out), "/dev/full", paths[1]])
        args = ["evaluate", *paths, "-o", target]
        if rng.random() < 0.1:
            args += ["--gate", rng.choice(["nan", "inf", "-1", "0.02"])]
        source = None
    else:
        names = rng.choice(IMPORT_BASES)
        paths = []
        for name in names:
            src, dst = FIXTURES / name, tmp / name
            shutil.copytree(src, dst, dirs_exist_ok=True) if src.is_dir() else shutil.copy(src, dst)
            paths.append(dst)
        victim = paths[rng.randrange(3)]
        if victim.is_dir():
            victim = rng.choice(sorted(victim.glob("*.txt")))
        mutate.mutate_text_file(victim, rng)
        target = rng.choice([str(out), "/dev/full", str(paths[0])])
        args = ["import", "--camera", str(paths[0]), "--poses", str(paths[1]), "--detections", str(paths[2]), "-o", target]
        source = None
    if kind == "localize":
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ws = read_structured_file(path).get("workspace")  # type: ignore[union-attr]
            if isinstance(ws, dict) and float(np.max(np.subtract(ws["max"], ws["min"]))) > 1.0:
                return_code_only = True
            else:
                return_code_only = False
        except Exception:  # noqa: BLE001 - the CLI itself reports malformed files below
            return_code_only = False
        if return_code_only:
            args = ["localize", str(path), "-q", "--method", "paper", "--resolution", "0.05", "--reach", "0.3", "-o", str(out)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = CliRunner().invoke(app, args)
    report.counts[f"cli_{kind}"] += 1
    if res.exit_code not in (0, 2) or (res.exception is not None and not isinstance(res.exception, SystemExit)):
        tb = "".join(traceback.format_exception(res.exception)) if res.exception else res.output
        report.fail(case, "traceback", f"{args}\n{tb}")
        return
    if res.exit_code == 2:
        lines = [ln for ln in res.stderr.splitlines() if ln.startswith("error: ")]
        if len(lines) != 1:
            report.fail(case, "multiline", res.stderr[:400])
            return
        names = tuple(a for a in args if "/" in a) + tuple(a for a in args if a.startswith("--"))  # a file or an option
        _check_error(report, case, lines[0].removeprefix("error: "), names if source else None)
        return
    report.counts["cli_ok"] += 1
    if out.exists() and target == str(out):
        try:
            json.loads(out.read_text(), parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
        except ValueError as exc:
            report.fail(case, "non_finite", f"{args}: output not strict JSON: {exc}")
        out.unlink()
    if kind == "localize" and source:
        problems = validate_session_schema(read_structured_file(source))
        if problems:
            report.fail(case, "schema", f"CLI accepted, schema refused: {problems[0][:300]}")


_BAG: list[bytes] = []


def bag_case(rng: random.Random, tmp: Path, report: Report, case: str) -> None:
    """A corrupted ROS 1 bag (bytes flipped, zeroed or cut) through read_bag or the CLI's import-bag."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        report.counts["bag_skipped"] += 1
        return
    if not _BAG:
        sys.path.insert(0, str(FIXTURES.parent))
        import io_scene

        io_scene.write_scene_bag(tmp / "scene.bag", "ros1")
        _BAG.append((tmp / "scene.bag").read_bytes())
    raw = bytearray(_BAG[0])
    op = rng.choice(["flip", "truncate", "zero", "none"])
    if op == "truncate":
        raw = raw[: rng.randrange(len(raw))]
    elif op != "none":
        for _ in range(rng.randint(1, 8)):
            raw[rng.randrange(len(raw))] = rng.randrange(256) if op == "flip" else 0
    path = tmp / "corrupt.bag"
    path.write_bytes(bytes(raw))
    opts = {"base_frame": "base_link", "camera_frame": "camera_optical_frame", "labels": ["tomato"]}
    if rng.random() < 0.3:
        from typer.testing import CliRunner

        from monovisual3d.cli import app

        out = tmp / "out.json"
        args = ["import-bag", str(path), "--base-frame", "base_link", "--camera-frame", "camera_optical_frame"]
        args += ["--detections", "/detections", "--label", "tomato", "-o", rng.choice([str(out), "/dev/full", str(path)])]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = CliRunner().invoke(app, args)
        report.counts["cli_import_bag"] += 1
        if res.exit_code not in (0, 2) or (res.exception is not None and not isinstance(res.exception, SystemExit)):
            tb = "".join(traceback.format_exception(res.exception)) if res.exception else res.output
            report.fail(case, "traceback", f"{args}\n{tb}")
        elif res.exit_code == 2:
            lines = [ln for ln in res.stderr.splitlines() if ln.startswith("error: ")]
            if len(lines) != 1:
                report.fail(case, "multiline", res.stderr[:400])
            else:
                _check_error(report, case, lines[0].removeprefix("error: "), None)
        return
    from monovisual3d.io import read_bag

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = read_bag(path, class_names=["tomato", "leaf"], **opts)
    except InputError as exc:
        _check_error(report, case, str(exc), None)
        return
    if not _finite_tree(result.session.to_dict()):
        report.fail(case, "non_finite", "read_bag session")
    report.counts["bag_read"] += 1


#: Share of loadable sessions that are also localised (the slow part); FUZZ_LOCALIZE_SHARE overrides.
LOCALIZE_SHARE = 0.3
#: Mix of case kinds: (kind, weight).
MIX = [("session", 72), ("evaluate", 10), ("import", 6), ("cli", 9), ("bag", 3), ("bounds", 4)]


def run(cases: int, seed: int, *, log: Any = None, start: int = 0) -> Report:
    """Run ``cases`` cases from ``seed``; case ``i`` uses ``random.Random(f"{seed}:{i}")``, so any one replays alone."""
    report = Report(seed, log=log)
    bases = mutate.base_sessions()
    kinds = [k for k, w in MIX for _ in range(w)]
    old = signal.signal(signal.SIGALRM, _alarm)
    t_start = time.perf_counter()
    usage0 = resource.getrusage(resource.RUSAGE_SELF)
    cpu0 = usage0.ru_utime + usage0.ru_stime
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    try:
        for i in range(start, start + cases):
            rng = random.Random(f"{seed}:{i}")
            kind = rng.choice(kinds)
            case = f"{seed}:{i}:{kind}"
            report.counts[f"case_{kind}"] += 1
            with tempfile.TemporaryDirectory(prefix="mv3d-fuzz-") as d:
                tmp = Path(d)
                t0 = time.perf_counter()
                signal.setitimer(signal.ITIMER_REAL, CASE_TIMEOUT_S)
                try:
                    if kind == "session":
                        session_case(rng, tmp, report, case, bases)
                    elif kind == "evaluate":
                        evaluate_case(rng, tmp, report, case)
                    elif kind == "import":
                        import_case(rng, tmp, report, case)
                    elif kind == "bag":
                        bag_case(rng, tmp, report, case)
                    elif kind == "bounds":
                        bounds.bounds_case(rng, tmp, report, case)
                    else:
                        cli_case(rng, tmp, report, case, bases)
                except Hang:
                    report.fail(case, "hang", f"over {CASE_TIMEOUT_S} s")
                except Exception as exc:  # noqa: BLE001 - the oracle: any other exception is a failure
                    report.fail(case, "traceback", "".join(traceback.format_exception(exc)))
                finally:
                    signal.setitimer(signal.ITIMER_REAL, 0)
                dt = time.perf_counter() - t0
                report.times[kind] += dt
            if dt > report.slowest[0]:
                report.slowest = (dt, case)
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            if rss > peak:
                peak, report.peak_case = rss, case
            if log is not None and (i + 1 - start) % 500 == 0:
                print(f"{i + 1} cases, {time.perf_counter() - t_start:.0f} s, {dict(report.counts)}", file=log, flush=True)
    finally:
        signal.signal(signal.SIGALRM, old)
    report.peak_rss_mib = peak
    report.wall_s = time.perf_counter() - t_start
    usage = resource.getrusage(resource.RUSAGE_SELF)
    report.cpu_s = usage.ru_utime + usage.ru_stime - cpu0
    return report


def main() -> None:
    global LOCALIZE_SHARE
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=13)
    ap.add_argument("--start", type=int, default=0, help="index of the first case (replay: --start I --cases 1)")
    ap.add_argument("--localize-share", type=float, default=LOCALIZE_SHARE)
    ap.add_argument("--json", type=Path, help="write the summary here")
    args = ap.parse_args()
    LOCALIZE_SHARE = args.localize_share
    report = run(args.cases, args.seed, log=sys.stderr, start=args.start)
    summary = report.summary()
    text = json.dumps(summary, indent=2, default=str)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    sys.exit(1 if any(k.startswith("fail:") for k in report.counts) else 0)


if __name__ == "__main__":
    main()
