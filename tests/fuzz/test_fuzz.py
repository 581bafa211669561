"""The fuzz suite of issue 13: hostile sessions, truth files, imports and bags; the oracle in ``runner.py``.

- ``test_fuzz_cases``: ``FUZZ_CASES`` (default 2,000) seeded cases (``FUZZ_SEED``, default 13) of the
  structural mutator, in-process (``load_session`` + ``localize``, ``evaluate``, ``import``,
  ``read_bag``) and through the CLI (Typer's runner);
- ``test_hypothesis_field_values``: hypothesis draws a hostile value for a field of a valid session;
- ``test_real_cli_subprocess``: a few of the nastiest inputs through a real ``monovisual3d`` process
  under an address-space limit and a timeout.

Replay one case: ``PYTHONPATH=src python tests/fuzz/runner.py --cases 1 --seed S`` replays case 0 of
seed S; a failing case is named ``seed:index:kind``.
"""

from __future__ import annotations

import copy
import json
import math
import os
import resource
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
import mutate  # noqa: E402
import runner  # noqa: E402

from monovisual3d import InputError, load_session  # noqa: E402

CASES = int(os.environ.get("FUZZ_CASES", "2000"))
SEED = int(os.environ.get("FUZZ_SEED", "13"))
#: Peak memory target of issue 13, MiB.
MAX_RSS_MIB = 2.5 * 1024


def test_fuzz_cases() -> None:
    report = runner.run(CASES, SEED)
    summary = report.summary()
    print(json.dumps(summary, indent=2, default=str))
    failures = {k: v for k, v in report.counts.items() if k.startswith("fail:")}
    assert not failures, json.dumps(summary["failures"], indent=2)[:6000]
    assert report.peak_rss_mib <= MAX_RSS_MIB, summary
    assert len(report.longest_error) <= runner.MAX_ERROR_CHARS
    # the mutator reaches every stage: some cases load, localise, evaluate and import
    for key in ("loaded", "localized", "input_error"):
        assert report.counts[key] > 0, summary


# ---------------------------------------------------------------------- hypothesis
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.integers(min_value=10**300, max_value=10**400),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=30),
    st.sampled_from([1e6 + 1, -1e308, 1e-320, 2**63, 32769, 0.0]),
)
hostile_json = st.recursive(
    scalars, lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=8), inner, max_size=5), max_leaves=20
)
BASES = mutate.base_sessions()


@seed(SEED)
@settings(
    max_examples=int(os.environ.get("FUZZ_HYPOTHESIS", "200")),
    deadline=None,
    derandomize=False,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(data=st.data())
def test_hypothesis_field_values(data: Any) -> None:
    base = copy.deepcopy(BASES[data.draw(st.integers(0, 1))])
    paths = [p for p in mutate._nodes(base) if p]
    path = data.draw(st.sampled_from(paths))
    value = data.draw(hostile_json)
    tree = mutate._set(base, path, value)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            session = load_session(tree)
    except InputError as exc:
        msg = str(exc)
        assert "\n" not in msg and len(msg) <= runner.MAX_ERROR_CHARS, msg
        return
    assert runner.validate_session_schema(tree) == [], (path, value)
    for view in session.views:
        assert math.isfinite(float(abs(view.T_base_optical).max()))


# ---------------------------------------------------------------------- real processes
def _bomb_session() -> str:
    text = "metadata:\n" + mutate._bomb(9)
    base = json.loads(json.dumps(BASES[0]))
    import yaml

    return text + yaml.safe_dump(base).replace("hfov_deg: 69.0", "hfov_deg: *b9")


@pytest.mark.parametrize(
    ("name", "content", "args", "expected"),
    [
        ("s.yaml", "bomb", ["localize", "s.yaml", "-q"], "s.yaml: metadata.b6: more than 5,000,000 values"),
        (
            "s.json",
            "rle",
            ["localize", "s.json", "-q"],
            "s.json: camera.width: got 100000, more than the 32768 pixels accepted",
        ),
        ("s.json", "example", ["localize", "s.json", "-q", "-o", "/dev/full"], "/dev/full: cannot write"),
        ("s.json", "device", ["localize", "/dev/zero", "-q"], "/dev/zero: is a device, expected a regular file"),
        ("s.json", "device", ["next-view", "s.json", "--candidates", "cap:100000"], "--candidates: got 'cap:100000', more than"),
        ("s.json", "device", ["simulate", "-o", "o", "--views", "ring:1000000"], "--views: got 'ring:1000000', more than"),
    ],
)
def test_real_cli_subprocess(tmp_path: Path, name: str, content: str, args: list[str], expected: str) -> None:
    if content == "bomb":
        text = _bomb_session()
    elif content == "rle":
        data = copy.deepcopy(BASES[0])
        data["camera"].update(width=100000, height=100000)
        data["views"][0]["detections"][0]["mask"] = {"size": [100000, 100000], "counts": [0, 10**10]}
        text = json.dumps(data)
    else:
        text = json.dumps(BASES[0])
    (tmp_path / name).write_text(text)
    if content == "example" and not Path("/dev/full").exists() or content == "device" and not Path("/dev/zero").exists():
        pytest.skip("needs /dev/full and /dev/zero")
    limit = int(MAX_RSS_MIB * 1024**2)

    def cap() -> None:  # pragma: no cover - runs in the child
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(__file__).parents[2] / "src"), os.environ.get("PYTHONPATH", "")]))
    if content == "example":  # the output is checked before computing: a cheap method is enough
        args = [*args, "--method", "paper", "--resolution", "0.05", "--reach", "0.3"]
    proc = subprocess.run(
        [sys.executable, "-c", "from monovisual3d.cli import main; main()", *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=cap,
        env=env,
    )
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: " + expected), proc.stderr[-2000:]
