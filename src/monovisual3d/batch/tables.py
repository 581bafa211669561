"""The two output tables of a batch, written in parts as results arrive and consolidated at the end.

Layout of an output folder::

    parts/fruit-000001-TOKEN.parquet, parts/sessions-000001-TOKEN.parquet, ...   (written as results arrive)
    fruit.parquet, fruit.csv, sessions.parquet, sessions.csv, summary.json  (consolidated)
    .lock   (held by the run writing to the folder)

Part names carry a token of the run that wrote them, so two runs never write
the same name even where the lock cannot be taken (a file system without
``flock``). The CSV files follow RFC 4180 (CRLF line ends, fields with a comma,
quote, CR or LF quoted), so any session id reads back as written.

A part is written atomically (temporary name, then rename), fruit before
sessions: a ``sessions`` part is the mark that its sessions are done. When a
session appears in several parts (re-run with other options, or retried after
a lost worker), the consolidated tables keep its last row and that row's fruit.
"""

from __future__ import annotations

import json
import math
import os
import re
import uuid
from pathlib import Path
from typing import Any

from .._extras import require
from ..errors import InputError, one_line

#: ``fruit`` columns and their pandas dtypes (one row per localised fruit).
FRUIT_COLUMNS: dict[str, str] = {
    "session_id": "string",
    "fruit": "int64",
    "x_m": "float64",
    "y_m": "float64",
    "z_m": "float64",
    "radius_m": "float64",
    "radius_std_m": "float64",
    "cov_xx_m2": "float64",
    "cov_xy_m2": "float64",
    "cov_xz_m2": "float64",
    "cov_yy_m2": "float64",
    "cov_yz_m2": "float64",
    "cov_zz_m2": "float64",
    "shape": "string",
    "semi_axes_m": "string",
    "quaternion_xyzw": "string",
    "residual_chi2": "float64",
    "dof": "Int64",
    "variance_factor": "float64",
    "score": "float64",
    "n_views": "Int64",
    "n_cells": "Int64",
    "association": "string",
    "extra": "string",
    "truth_id": "Int64",
    "error_m": "float64",
}

#: ``sessions`` columns and their pandas dtypes (one row per session).
SESSION_COLUMNS: dict[str, str] = {
    "session_id": "string",
    "path": "string",
    "status": "string",
    "error": "string",
    "error_type": "string",
    "n_views": "Int64",
    "n_detections": "Int64",
    "n_fruit": "Int64",
    "runtime_s": "float64",
    "method": "string",
    "options": "string",
    "input_sha256": "string",
    "config_sha256": "string",
    "worker": "string",
    "warnings": "string",
    "verdict": "string",
    "causes": "string",
    "variance_factor": "float64",
    "edge_noise_alpha": "float64",
    "n_truth": "Int64",
    "n_true_positives": "Int64",
    "recall": "float64",
    "precision": "float64",
    "error_mean_m": "float64",
    "error_median_m": "float64",
    "error_max_m": "float64",
    "radius_error_mean_m": "float64",
}

#: Files a batch writes into its output folder (besides ``parts/`` and ``.lock``).
WRITTEN_FILES = ("fruit.parquet", "fruit.csv", "sessions.parquet", "sessions.csv", "summary.json", ".lock")
#: Error types that say nothing about the input (a lost worker, a cancelled task): ``resume`` runs them again.
TRANSIENT_ERRORS = frozenset({"KilledWorker", "CancelledError", "FutureCancelledError"})

_PART = re.compile(r"^(fruit|sessions)-(\d{6,})(?:-([0-9a-f]{8,32}))?\.parquet$")


def require_libraries() -> None:
    """Raise :class:`~monovisual3d.errors.MissingExtra` unless pandas and pyarrow (the ``dask`` extra), which write the
    tables, are installed: checked before a batch starts, so that a run without them does no work it cannot keep."""
    require("pandas", "dask")
    require("pyarrow", "dask")


def _pandas() -> Any:
    require_libraries()
    import pandas as pd

    return pd


def frame(rows: list[dict[str, Any]], columns: dict[str, str]) -> Any:
    """A DataFrame with exactly ``columns`` (missing values as NA/NaN) and their dtypes."""
    pd = _pandas()
    df = pd.DataFrame(rows, columns=list(columns))
    return df.astype(columns)


def empty(columns: dict[str, str]) -> Any:
    return frame([], columns)


def _write_atomic(df: Any, path: Path) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    df.to_parquet(tmp, index=False)
    os.replace(tmp, path)


class PartWriter:
    """Buffers rows and writes them as numbered Parquet parts under ``output/parts``.

    Parameters
    ----------
    output : Path, the batch's output folder
    part_size : int, sessions per part
    part_seconds : float, longest time rows wait in the buffer, seconds
    """

    def __init__(self, output: Path, part_size: int = 100, part_seconds: float = 5.0) -> None:
        self.dir = Path(output) / "parts"
        self.dir.mkdir(parents=True, exist_ok=True)
        self.part_size = part_size
        self.part_seconds = part_seconds
        numbers = [int(m.group(2)) for p in self.dir.iterdir() if (m := _PART.match(p.name))]
        self.next_part = max(numbers, default=0) + 1
        self.token = uuid.uuid4().hex[:12]  # this run's mark in its part names: never the name of another run's part
        self.sessions: list[dict[str, Any]] = []
        self.fruit: list[dict[str, Any]] = []
        self.last_flush: float | None = None

    def add(self, session_row: dict[str, Any], fruit_rows: list[dict[str, Any]], now: float) -> None:
        """Buffer one session's rows; write a part when the buffer is full or old enough."""
        self.sessions.append(session_row)
        self.fruit.extend(fruit_rows)
        if self.last_flush is None:
            self.last_flush = now
        if len(self.sessions) >= self.part_size or now - self.last_flush >= self.part_seconds:
            self.flush(now)

    def flush(self, now: float | None = None) -> None:
        """Write the buffered rows as one part (fruit first, then sessions)."""
        if not self.sessions:
            return
        n = self.next_part
        _write_atomic(frame(self.fruit, FRUIT_COLUMNS), self.dir / f"fruit-{n:06d}-{self.token}.parquet")
        _write_atomic(frame(self.sessions, SESSION_COLUMNS), self.dir / f"sessions-{n:06d}-{self.token}.parquet")
        self.next_part += 1
        self.sessions, self.fruit = [], []
        self.last_flush = now


def has_parts(output: Path) -> bool:
    d = Path(output) / "parts"
    return d.is_dir() and any(_PART.match(p.name) for p in d.iterdir())


def read_parts(output: Path) -> tuple[Any, Any]:
    """All parts of ``output``, deduplicated: (fruit, sessions), each session's last row and its fruit."""
    pd = _pandas()
    d = Path(output) / "parts"
    found: dict[tuple[int, str], dict[str, Path]] = {}  # (number, run token) -> {"fruit": path, "sessions": path}
    if d.is_dir():
        for p in d.iterdir():
            if m := _PART.match(p.name):
                found.setdefault((int(m.group(2)), m.group(3) or ""), {})[m.group(1)] = p
    sessions, fruit = [], []
    for n, key in enumerate(sorted(found)):
        if "sessions" not in found[key]:
            continue  # the client stopped between the two writes: its sessions count as not done
        s = pd.read_parquet(found[key]["sessions"])
        s["_part"] = n
        sessions.append(s)
        if "fruit" in found[key]:
            f = pd.read_parquet(found[key]["fruit"])
            f["_part"] = n
            fruit.append(f)
    if not sessions:
        return empty(FRUIT_COLUMNS), empty(SESSION_COLUMNS)
    s = pd.concat(sessions, ignore_index=True).drop_duplicates("session_id", keep="last")
    f = pd.concat(fruit, ignore_index=True) if fruit else empty(FRUIT_COLUMNS).assign(_part=0)
    f = f.merge(s[["session_id", "_part"]], on=["session_id", "_part"], how="inner")
    s = s.drop(columns="_part").sort_values("session_id", kind="stable").reset_index(drop=True)
    f = f.drop(columns="_part").sort_values(["session_id", "fruit"], kind="stable").reset_index(drop=True)
    return f.astype(FRUIT_COLUMNS)[list(FRUIT_COLUMNS)], s.astype(SESSION_COLUMNS)[list(SESSION_COLUMNS)]


def done_keys(output: Path) -> set[tuple[str, str, str]]:
    """``(session_id, input_sha256, config_sha256)`` of the sessions already in ``output``'s parts.

    Sessions that failed for a reason outside their input (:data:`TRANSIENT_ERRORS`) are not done.
    """
    _, s = read_parts(output)
    s = s[~s["error_type"].isin(list(TRANSIENT_ERRORS)).fillna(False).astype(bool)]
    return set(zip(s["session_id"], s["input_sha256"], s["config_sha256"]))


def summarize(fruit: Any, sessions: Any) -> dict[str, Any]:
    """Counts, and where there was ground truth the pooled recall, precision and errors (metres).

    Pooled: ``recall = sum(true positives) / sum(truth objects)`` over the
    evaluated sessions, ``precision = sum(true positives) / sum(fruit)``; the
    errors are over every fruit matched to a truth object.
    """
    ok = sessions["status"] == "ok"
    out: dict[str, Any] = {
        "n_sessions": int(len(sessions)),
        "n_ok": int(ok.sum()),
        "n_error": int((~ok).sum()),
        "n_fruit": int(len(fruit)),
        "runtime_s_total": float(sessions["runtime_s"].sum()),
    }
    ev = sessions[ok & sessions["n_truth"].notna()]
    if len(ev):
        tp, n_truth, n_est = int(ev["n_true_positives"].sum()), int(ev["n_truth"].sum()), int(ev["n_fruit"].sum())
        err = fruit["error_m"].dropna()
        out["evaluation"] = {
            "n_sessions": int(len(ev)),
            "n_truth": n_truth,
            "n_true_positives": tp,
            "recall": tp / n_truth if n_truth else math.nan,
            "precision": tp / n_est if n_est else math.nan,
            "error_mean_m": float(err.mean()) if len(err) else math.nan,
            "error_median_m": float(err.median()) if len(err) else math.nan,
            "error_max_m": float(err.max()) if len(err) else math.nan,
        }
    return out


def strict_json(value: Any) -> Any:
    """``value`` with every non-finite float replaced by ``None`` (JSON ``null``: ``NaN`` is not JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [strict_json(v) for v in value]
    return value


class OutputLock:
    """An exclusive lock on a batch output folder (``OUTPUT/.lock``, ``flock``), held while a run writes to it.

    A second run on the same folder is refused with a one-line :class:`InputError`
    instead of interleaving its parts and tables with the first. The lock is
    released when the run ends, also when it is killed (the kernel drops it).
    On a system without ``fcntl`` (Windows) no lock is taken; the part names
    still never collide.
    """

    def __init__(self, output: Path) -> None:
        self.path = Path(output) / ".lock"
        self.file: Any = None

    def __enter__(self) -> OutputLock:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            return self
        self.file = open(self.path, "a+", encoding="utf-8")  # noqa: SIM115 - held until __exit__
        try:
            fcntl.flock(self.file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.file.close()
            self.file = None
            raise InputError(
                f"{one_line(str(self.path.parent))}: another batch is writing to this folder (it holds {self.path.name}); "
                "wait for it to end or choose another --output"
            ) from None
        self.file.seek(0)
        self.file.truncate()
        self.file.write(f"{os.getpid()}\n")
        self.file.flush()
        return self

    def __exit__(self, *exc: object) -> None:
        if self.file is not None:
            self.file.close()  # closing releases the flock
            self.file = None


def consolidate(output: Path) -> tuple[Any, Any, dict[str, Any]]:
    """Merge the parts into ``fruit``/``sessions`` Parquet and CSV files and ``summary.json``."""
    output = Path(output)
    fruit, sessions = read_parts(output)
    summary = summarize(fruit, sessions)
    for name, df in (("fruit", fruit), ("sessions", sessions)):
        _write_atomic(df, output / f"{name}.parquet")
        tmp = output / f".{name}.csv.tmp"
        df.to_csv(tmp, index=False, lineterminator="\r\n")  # RFC 4180: a CR or LF inside a field is quoted
        os.replace(tmp, output / f"{name}.csv")
    tmp = output / ".summary.json.tmp"
    tmp.write_text(json.dumps(strict_json(summary), indent=2, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(tmp, output / "summary.json")
    return fruit, sessions, summary


def read_tables(output: str | Path) -> tuple[Any, Any]:
    """The consolidated ``(fruit, sessions)`` of a batch output folder, with the documented dtypes."""
    pd = _pandas()
    output = Path(output)
    return (
        pd.read_parquet(output / "fruit.parquet").astype(FRUIT_COLUMNS),
        pd.read_parquet(output / "sessions.parquet").astype(SESSION_COLUMNS),
    )
