"""What a worker does with one session: parse, localise, evaluate, and turn the result into table rows.

Everything here runs on a Dask worker (or in-process) and touches no file: the
client sends the session's text, so workers need no shared file system.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import warnings as py_warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._structured import read_capped_bytes
from ..errors import InputError
from ..result import DetectedObject, Result

#: ``extra`` keys of a :class:`DetectedObject` that have their own ``fruit`` column.
_OWN_COLUMNS = ("radius_std", "n_views")


@dataclass(frozen=True)
class Job:
    """One session to localise, as sent to a worker.

    Attributes
    ----------
    session_id : str
    path : str, the session file (for messages and the ``path`` column)
    text : str, the file's content
    input_sha256 : str, SHA-256 of the file's bytes
    method : str
    options : dict, the method options
    config_sha256 : str, SHA-256 of the method and its options (see :func:`config_hash`)
    truth_path, truth_text : str or None, the ``truth.json`` beside the session
    """

    session_id: str
    path: str
    text: str
    input_sha256: str
    method: str
    options: dict[str, Any] = field(default_factory=dict)
    config_sha256: str = ""
    truth_path: str | None = None
    truth_text: str | None = None


def options_json(options: dict[str, Any]) -> str:
    """Canonical JSON of method options (sorted keys; values JSON cannot hold are written with ``repr``)."""
    return json.dumps(options, sort_keys=True, default=repr)


def input_hash(data: bytes) -> str:
    """SHA-256 (hex) of a session file's bytes: the ``input_sha256`` column and the key of ``resume``."""
    return hashlib.sha256(data).hexdigest()


def config_hash(method: str, options: dict[str, Any]) -> str:
    """SHA-256 (hex) of a method and its options: equal for equal settings, whatever the key order.

    Examples
    --------
    >>> config_hash("paper", {"k": 3, "resolution": 0.01}) == config_hash("paper", {"resolution": 0.01, "k": 3})
    True
    """
    return hashlib.sha256(
        json.dumps({"method": method, "options": json.loads(options_json(options))}, sort_keys=True).encode()
    ).hexdigest()


def one_line(exc: BaseException) -> str:
    """The error as one line: an :class:`InputError`'s own message, otherwise ``Type: message``."""
    text = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def session_row(job: Job, **values: Any) -> dict[str, Any]:
    """A ``sessions`` row for ``job``: its identity and settings plus ``values``."""
    return {
        "session_id": job.session_id,
        "path": job.path,
        "method": job.method,
        "options": options_json(job.options),
        "input_sha256": job.input_sha256,
        "config_sha256": job.config_sha256,
        **values,
    }


def fruit_rows(session_id: str, result: Result) -> list[dict[str, Any]]:
    """One ``fruit`` row per object of ``result`` (positions in metres, base frame): its shape (``shape``, ``semi_axes_m``
    and ``quaternion_xyzw`` as JSON lists) and its residuals under the sensor model (``residual_chi2``, ``dof``,
    ``variance_factor`` of ``result.quality["objects"]``) included."""
    per_object = result.quality.get("objects", [])
    rows = []
    for i, obj in enumerate(result.objects):
        row = _fruit_row(session_id, i, obj)
        q = per_object[i] if i < len(per_object) else {}
        row.update({k: q.get(k) for k in ("residual_chi2", "dof", "variance_factor")})
        rows.append(row)
    return rows


def quality_columns(result: Result) -> dict[str, Any]:
    """The ``sessions`` row's ``verdict``, ``causes`` (cause IDs, comma separated), ``variance_factor`` and
    ``edge_noise_alpha`` (the raised edge noise the session was localised with, ``quality.edge_noise.alpha``; NaN where
    it was not raised) of ``result.quality`` (NA where the method has no quality model)."""
    q = result.quality
    if not q:
        return {}
    return {
        "verdict": q.get("verdict"),
        "causes": ",".join(str(c.get("cause")) for c in q.get("causes", [])),
        "variance_factor": q.get("variance_factor"),
        "edge_noise_alpha": float((q.get("edge_noise") or {}).get("alpha", math.nan)),
    }


def _fruit_row(session_id: str, index: int, obj: DetectedObject) -> dict[str, Any]:
    x, y, z = (float(v) for v in obj.position)
    row: dict[str, Any] = {"session_id": session_id, "fruit": index, "x_m": x, "y_m": y, "z_m": z, "score": float(obj.score)}
    row["radius_m"] = float(obj.radius) if obj.radius is not None else math.nan
    row["shape"] = obj.shape
    for name, value in (("semi_axes_m", obj.semi_axes), ("quaternion_xyzw", obj.quaternion_xyzw)):
        row[name] = None if value is None else json.dumps([float(v) for v in value])
    radius_std, n_views = (obj.extra.get(k) for k in _OWN_COLUMNS)
    row["radius_std_m"] = float(radius_std) if radius_std is not None else math.nan
    cov = np.full((3, 3), np.nan) if obj.covariance is None else np.asarray(obj.covariance, dtype=float)
    for name, (a, b) in zip(("xx", "xy", "xz", "yy", "yz", "zz"), ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        row[f"cov_{name}_m2"] = float(cov[a, b])
    if obj.associations:
        row["n_views"] = len(obj.associations)
        row["association"] = json.dumps({str(k): int(v) for k, v in sorted(obj.associations.items())})
    elif n_views is not None:
        row["n_views"] = int(n_views)
    row["n_cells"] = None if obj.n_cells is None else int(obj.n_cells)
    rest = {k: v for k, v in obj.extra.items() if k not in _OWN_COLUMNS}
    row["extra"] = json.dumps(rest, default=_jsonable) if rest else None
    return row


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return repr(value)


def evaluate_rows(fruit: list[dict[str, Any]], truth: Any) -> dict[str, Any]:
    """Fill ``truth_id``/``error_m`` of ``fruit`` (Hungarian pairs) and return the session's evaluation columns.

    Parameters
    ----------
    fruit : list of dict, ``fruit`` rows of one session (changed in place)
    truth : monovisual3d.truth.ObjectSet
    """
    from ..metrics import evaluate, match

    est = np.array([[r["x_m"], r["y_m"], r["z_m"]] for r in fruit], dtype=float).reshape(-1, 3)
    radii = np.array([r["radius_m"] for r in fruit], dtype=float)
    ei, ti = match(est, truth.positions)
    for e, t in zip(ei, ti):
        fruit[e]["truth_id"] = int(t)
        fruit[e]["error_m"] = float(np.linalg.norm(est[e] - truth.positions[t]))
    m = evaluate(est, truth.positions, truth_radii=truth.radii, estimate_radii=radii if np.isfinite(radii).any() else None)
    return {
        "n_truth": m.n_truth,
        "n_true_positives": m.true_positives,
        "recall": m.recall,
        "precision": m.precision,
        "error_mean_m": m.euclidean_mean,
        "error_median_m": m.euclidean_median,
        "error_max_m": m.euclidean_max,
        "radius_error_mean_m": math.nan if m.radius_error_mean is None else m.radius_error_mean,
    }


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return "in-process"


def run_job(job: Job, localizer: Callable[..., Result] | None = None) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Localise one session; never raises for a bad session.

    Parameters
    ----------
    job : Job
    localizer : callable(session, method=..., **options) -> Result, default :func:`monovisual3d.localize`

    Returns
    -------
    session_row : dict, status ``ok`` or ``error`` with the one-line error
    fruit_rows : list of dict, empty when the session failed
    """
    from .._structured import parse_structured_text
    from ..completeness import incomplete_reasons, merge_reasons
    from ..session.load import session_from_dict
    from ..truth import objects_from_dict

    if localizer is None:
        from ..api import localize as localizer
    t0 = time.perf_counter()
    counts: dict[str, Any] = {}
    try:
        # the session's warnings go into its row, not to the worker's stderr as raw Python warnings
        with py_warnings.catch_warnings(record=True) as caught:
            py_warnings.simplefilter("always")
            session = session_from_dict(parse_structured_text(job.text, job.path), job.path)
            counts = {"n_views": len(session.views), "n_detections": sum(len(v.detections) for v in session.views)}
            result = localizer(session, method=job.method, **job.options)
        fruit = fruit_rows(job.session_id, result)
        raised = [str(w.message) for w in caught if str(w.message) not in result.warnings]
        warnings = merge_reasons([*result.warnings, *raised], incomplete_reasons(session, result))  # empty, boxes left over
        evaluation: dict[str, Any] = {}
        if job.truth_text is not None:
            try:
                truth = objects_from_dict(parse_structured_text(job.truth_text, job.truth_path or "truth.json"))
            except InputError as exc:
                warnings.append(f"{job.truth_path}: not evaluated: {one_line(exc)}")
            else:
                evaluation = evaluate_rows(fruit, truth)
    except Exception as exc:  # a bad session is recorded, never raised: the batch goes on
        row = session_row(job, status="error", error=one_line(exc), error_type=type(exc).__name__, **counts)
        row.update(runtime_s=time.perf_counter() - t0, worker=_worker_name())
        return row, []
    row = session_row(
        job,
        status="ok",
        n_fruit=len(fruit),
        warnings=json.dumps(warnings),
        worker=_worker_name(),
        **quality_columns(result),
        **counts,
        **evaluation,
    )
    row["runtime_s"] = time.perf_counter() - t0
    return row, fruit


def run_jobs(
    jobs: list[Job], localizer: Callable[..., Result] | None = None
) -> list[tuple[dict[str, Any], list[dict[str, Any]]]]:
    """:func:`run_job` over several jobs, in order: one Dask task for a chunk of sessions.

    Returns
    -------
    list of (session_row, fruit_rows), one per job
    """
    return [run_job(job, localizer) for job in jobs]


def _utf8(data: bytes, path: Path) -> str:
    """Strict UTF-8 text (a BOM allowed), as every reader of the package: invalid bytes are an error, not replaced."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise UnicodeError(f"{path}: not UTF-8 text (invalid byte 0x{data[exc.start]:02x} at offset {exc.start})") from None


def make_job(
    path: Path, session_id: str, truth_path: Path | None, method: str, options: dict[str, Any], config_sha256: str
) -> Job:
    """Read a session (and its truth) into a :class:`Job`.

    Raises :class:`InputError` when a file cannot be read, is not a regular file
    (a device, a FIFO) or is larger than :data:`~monovisual3d.limits.MAX_FILE_BYTES`.
    """
    data = read_capped_bytes(path)
    truth_text = _utf8(read_capped_bytes(truth_path), truth_path) if truth_path is not None else None
    return Job(
        session_id=session_id,
        path=str(path),
        text=_utf8(data, path),
        input_sha256=input_hash(data),
        method=method,
        options=dict(options),
        config_sha256=config_sha256,
        truth_path=str(truth_path) if truth_path is not None else None,
        truth_text=truth_text,
    )
