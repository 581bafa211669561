"""Fuzz cases of issue 23 (nothing unbounded, nothing lost), one kind ``bounds`` of the runner's mix.

Each case draws one class and checks its own invariant besides the common oracle
(exit code 0, 1 or 2; one ``error:`` line; no traceback; within the case timeout):

- ``device``: ``/dev/zero``, ``/dev/urandom`` or a FIFO as the input of ``localize``, ``view -r``, ``evaluate``,
  ``next-view`` or ``batch``: refused (exit 2) without reading;
- ``count``: a huge count or size in an option (``next-view --candidates cap:N``, ``simulate --views ring:N``,
  ``--false-positives``, ``--pose-error-mm``/``-deg``, ``--seed``, ``--n-fruit``, ``--supersample``,
  ``localize --resolution``): refused (exit 2) in one line naming the option;
- ``symlink``: a tree of sessions with links to ``.`` and ``..`` (and to a sibling): a glob finds each session once;
- ``concurrent``: a batch on an output folder another run holds: refused, the folder untouched;
- ``odd_names``: session folders named with CR, LF, commas, quotes and other odd characters: the batch tables
  (Parquet and CSV read back) hold exactly one row per session;
- ``same_file``: an output equal to an input (``next-view -o`` the session or the candidates, ``simulate`` into the
  folder of its scene, ``batch`` over its own ``summary.json``): refused, the input unchanged.

Brackets in terminal text (``[/x]``) are another helper's class and are not drawn here.
"""

from __future__ import annotations

import io
import json
import os
import random
import traceback
import warnings
from pathlib import Path
from typing import Any

from monovisual3d.examples import example_session_path

#: The classes of this kind and their weights.
CLASSES = [("device", 2), ("count", 4), ("symlink", 2), ("concurrent", 1), ("odd_names", 1), ("same_file", 2)]
#: A fast localisation for the batch cases.
FAST = {"method": "paper", "resolution": 0.05, "reach": 0.3, "backend": "numpy"}
#: Characters odd in a folder name (CSV delimiters and quotes, line ends, shell and markup characters).
ODD_CHARS = ["\r", "\n", ",", '"', "'", ";", "\t", " ", "é", "😀", "\\", "$", "*", "%", "#"]


def _cli(args: list[str]) -> tuple[int, str, BaseException | None]:
    from typer.testing import CliRunner

    from monovisual3d.cli import app

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = CliRunner().invoke(app, args)
    exc = res.exception if res.exception is not None and not isinstance(res.exception, SystemExit) else None
    return res.exit_code, res.stderr, exc


def _check_cli(report: Any, case: str, args: list[str], *, want: tuple[int, ...] = (0, 1, 2)) -> int:
    """Run the CLI and apply the common oracle; returns the exit code (-1 when it failed the oracle)."""
    code, err, exc = _cli(args)
    if exc is not None or code not in (0, 1, 2):
        tb = "".join(traceback.format_exception(exc)) if exc is not None else err
        report.fail(case, "traceback", f"{args!r}\n{tb}")
        return -1
    if code == 2 and len([ln for ln in err.splitlines() if ln.startswith("error: ")]) != 1:
        report.fail(case, "multiline", f"{args!r}: {err[:400]}")
        return -1
    if code not in want:
        report.fail(case, "bounds", f"{args!r}: exit {code}, expected {want}: {err[:300]}")
        return -1
    return code


def _session(tmp: Path, name: str = "s.json") -> Path:
    path = tmp / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(example_session_path().read_bytes())
    return path


def device_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    if rng.random() < 0.3:
        device = tmp / "fifo.json"
        os.mkfifo(device)
    else:
        device = Path(rng.choice(["/dev/zero", "/dev/urandom"]))
    s = str(_session(tmp))
    args = rng.choice(
        [
            ["localize", str(device), "-q"],
            ["view", s, "-r", str(device), "-o", str(tmp / "v.html")],
            ["evaluate", str(device), s],
            ["next-view", str(device), "--candidates", "cap:8"],
            ["next-view", s, "--candidates", str(device)],
            ["batch", str(device), "-o", str(tmp / "b"), "--workers", "0", "-q"],
        ]
    )
    _check_cli(report, case, args, want=(2,))


def count_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    huge = rng.choice(["100000", "99999999999999999999999", "1e9", "1e300", str(2**64)])
    s = str(_session(tmp))
    out = str(tmp / "sim")
    choices = [
        ["next-view", s, "--candidates", f"cap:{rng.choice(['5001', '100000', '99999999999999999999999', str(2**64)])}"],
        ["simulate", "-o", out, "--views", f"ring:{huge if 'e' not in huge else 1000000}"],
        ["simulate", "-o", out, "--views", f"hemisphere:{huge if 'e' not in huge else 100000}:90"],
        ["simulate", "-o", out, "--false-positives", huge],
        ["simulate", "-o", out, "--pose-error-mm", huge],
        ["simulate", "-o", out, "--pose-error-deg", huge],
        ["simulate", "-o", out, "--seed", rng.choice(["-1", "-99999999999"])],
        ["simulate", "-o", out, "--scene", "random", "--n-fruit", huge if "e" not in huge else "1000000000"],
        ["simulate", "-o", out, "--supersample", rng.choice(["50", "1000"])],
        ["localize", s, "-q", "--resolution", rng.choice(["1e-9", "1e-300", "0.0001"])],
        ["localize", s, "-q", "--time-limit", rng.choice(["-1", "nan", "0", "1e30"])],
    ]
    _check_cli(report, case, rng.choice(choices), want=(2,))


def symlink_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    from monovisual3d.batch import find_sessions

    root = tmp / "runs"
    n = rng.randint(1, 3)
    for i in range(n):
        _session(root / f"r{i}", "session.json")
    for i in range(rng.randint(1, 3)):
        where = root if rng.random() < 0.5 else root / f"r{rng.randrange(n)}"
        os.symlink(rng.choice([".", "..", str(root), str(root / "r0")]), where / f"link{i}")
    pattern = rng.choice(["runs/**/session.json", "runs/**", "runs/*/session.json", "runs/*/*/session.json", "runs"])
    cwd = os.getcwd()
    os.chdir(tmp)
    try:
        found = find_sessions([pattern])
    except Exception as exc:  # noqa: BLE001 - the oracle: a glob that matches nothing is an InputError
        if type(exc).__name__ != "InputError":
            report.fail(case, "traceback", "".join(traceback.format_exception(exc)))
        return
    finally:
        os.chdir(cwd)
    real = [os.path.realpath(s.path) for s in found]
    if len(real) != len(set(real)):
        report.fail(case, "bounds", f"{pattern}: a session found twice: {sorted(real)}")
    if pattern != "runs/*/*/session.json" and len(found) != n:
        report.fail(case, "bounds", f"{pattern}: found {len(found)} sessions, expected {n}")


def concurrent_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    from monovisual3d.batch import run, tables
    from monovisual3d.errors import InputError

    s = _session(tmp / "runs" / "a", "session.json")
    out = tmp / "out"
    out.mkdir()
    with tables.OutputLock(out):
        try:
            run([s], out, workers=0, **FAST)
        except InputError as exc:
            if "another batch is writing to this folder" not in str(exc):
                report.fail(case, "bounds", f"unexpected error: {exc}")
        else:
            report.fail(case, "bounds", "a second run on a locked output folder was not refused")
    if tables.has_parts(out):
        report.fail(case, "bounds", "the refused run wrote parts")


def odd_names_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    import pandas as pd

    from monovisual3d.batch import run

    root = tmp / "runs"
    names = {"".join(rng.choice(ODD_CHARS + ["a", "b"]) for _ in range(rng.randint(1, 6))) for _ in range(rng.randint(1, 3))}
    names = {n for n in names if n not in (".", "..") and not n.startswith((" ", "."))} or {"plain"}
    for name in names:
        _session(root / name, "session.json")
    _, sessions = run([root], tmp / "out", workers=0, **FAST)
    if len(sessions) != len(names):
        report.fail(case, "bounds", f"{len(sessions)} rows for {len(names)} sessions: {sorted(names)!r}")
    raw = (tmp / "out" / "sessions.csv").read_bytes().decode("utf-8")
    back = pd.read_csv(io.StringIO(raw, newline=""), dtype={"session_id": "string"}, keep_default_na=False)
    if sorted(back["session_id"]) != sorted(sessions["session_id"]):
        report.fail(case, "bounds", f"sessions.csv does not read back: {list(back['session_id'])!r}")
    json.loads((tmp / "out" / "summary.json").read_text(), parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))


def same_file_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    s = _session(tmp)
    cands = tmp / "c.json"
    cands.write_text(json.dumps({"poses": [{"position": [0.2, 0.0, 0.0], "quaternion_xyzw": [0, 0, 0, 1]}]}))
    sim = tmp / "sim"
    sim.mkdir()
    scene = sim / "scene.json"
    scene.write_text(json.dumps({"fruits": [{"centre": [0.6, 0.0, 0.45], "radius": 0.03}]}))
    summary = tmp / "out" / "summary.json"
    summary.parent.mkdir()
    summary.write_bytes(s.read_bytes())
    args, victim = rng.choice(
        [
            (["next-view", str(s), "--candidates", str(cands), "-o", str(s)], s),
            (["next-view", str(s), "--candidates", str(cands), "-o", str(cands)], cands),
            (["localize", str(s), "-q", "-o", str(s)], s),
            (["simulate", "--scene", str(scene), "-o", str(sim), "--no-images"], scene),
            (["batch", str(summary), "-o", str(summary.parent), "--workers", "0", "-q"], summary),
        ]
    )
    before = victim.read_bytes()
    _check_cli(report, case, args, want=(2,))
    if victim.read_bytes() != before:
        report.fail(case, "bounds", f"{args!r} changed its input {victim}")


CASES = {
    "device": device_case,
    "count": count_case,
    "symlink": symlink_case,
    "concurrent": concurrent_case,
    "odd_names": odd_names_case,
    "same_file": same_file_case,
}


def _has_tables() -> bool:
    try:
        import pandas  # noqa: F401
        import pyarrow  # noqa: F401
    except ImportError:
        return False
    return True


def bounds_case(rng: random.Random, tmp: Path, report: Any, case: str) -> None:
    """One case of a class drawn from :data:`CLASSES` (see the module docstring)."""
    name = rng.choice([k for k, w in CLASSES for _ in range(w)])
    if name in ("concurrent", "odd_names") and not _has_tables():
        name = "same_file"  # the batch needs the [dask] extra (pandas, pyarrow)
    report.counts[f"bounds_{name}"] += 1
    CASES[name](rng, tmp, report, f"{case}:{name}")
