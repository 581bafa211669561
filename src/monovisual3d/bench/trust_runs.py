"""One session through the user's path, scored: what ``bench trust`` records of each clean or mistaken session.

:func:`run_session` does what ``monovisual3d localize --strict`` does with a session file: load it (the loader's
warnings), localise, add the completeness reasons, and say the exit code ``--strict`` would give (2: refused,
1: flagged, 0: answered). :func:`score_session` adds what the truth and the clean answer tell of it: the error,
each fruit's NEES, whether the answer is the clean one within :data:`SAME_ANSWER_M` with covariances that cover
the error, and whether a message names the mistake.
"""

from __future__ import annotations

import contextlib
import copy
import ctypes
import threading
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from ..api import localize
from ..budget import TimeLimitExceeded
from ..completeness import incomplete_reasons
from ..errors import InputError
from ..metrics import match
from ..session.load import load_session

#: An answer within this distance of the clean answer (every object, metres) is the clean answer.
SAME_ANSWER_M = 0.003
#: NEES below this covers the error: the 95 % quantile of chi-square with 3 degrees of freedom.
NEES_95 = float(chi2.ppf(0.95, 3))
#: Smallest gate (metres) for pairing an object with a true fruit when scoring its NEES (as ``evaluate``'s).
MIN_GATE_M = 0.02
#: Verdict of a result without a ``quality`` block (before the quality model): nothing flagged.
NO_QUALITY_VERDICT = "ok"
#: Default limit of one session's load and localisation, CPU seconds: a run past it counts as timed out (not
#: caught). Clean sessions of the bench use 0.3-4 CPU seconds.
RUN_LIMIT_S = 10.0
#: Seconds between two looks of the CPU-time watchdog.
CPU_POLL_S = 0.05


@dataclass
class Outcome:
    """What a user sees of one session: refused, flagged or answered, with every message.

    Attributes
    ----------
    exit_code : int, what ``localize --strict`` would exit with: 2 refused (InputError), 1 flagged (or a traceback),
        0 answered
    error : str or None, the InputError's message (refused), or the type and message of any other exception
    crashed : bool, an exception other than InputError (a bug)
    timed_out : bool, stopped after the run limit
    messages : list of str, the loader's warnings, the method's and the completeness reasons, each once
    verdict : str, the quality verdict (``ok`` without a quality block)
    causes : list of str, the quality cause IDs
    positions : ndarray, shape (K, 3), metres
    covariances : list of (3, 3) ndarray or None, per object
    runtime_s : float, wall-clock seconds
    cpu_s : float, CPU seconds of the process (all its threads) during the run
    """

    exit_code: int
    error: str | None = None
    crashed: bool = False
    timed_out: bool = False
    messages: list[str] = field(default_factory=list)
    verdict: str = NO_QUALITY_VERDICT
    causes: list[str] = field(default_factory=list)
    positions: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    covariances: list[Any] = field(default_factory=list)
    runtime_s: float = 0.0
    cpu_s: float = 0.0

    @property
    def refused(self) -> bool:
        return self.exit_code == 2 and not self.crashed and not self.timed_out

    @property
    def flagged(self) -> bool:
        """``--strict`` exits 1 and a message says why."""
        return self.exit_code == 1 and bool(self.messages)

    @property
    def alarm(self) -> bool:
        """Any warning, a refusal, or a verdict that is not ``ok`` (a false alarm on a clean session); a run stopped
        by the run limit is counted apart (``timed_out``)."""
        return bool(self.messages) or self.verdict != NO_QUALITY_VERDICT or (self.exit_code != 0 and not self.timed_out)


def run_session(
    session: dict[str, Any] | Any, options: dict[str, Any] | None = None, *, limit_s: float | None = RUN_LIMIT_S
) -> Outcome:
    """Load ``session`` (a session dict, or an already built Session) and localise it as the CLI does; never raises.

    Parameters
    ----------
    session : dict (as written to a file) or Session
    options : keyword options of :func:`monovisual3d.localize` (e.g. ``calibrate="hand-eye"``)
    limit_s : float or None, CPU seconds after which the run is stopped and recorded as timed out
    """
    start, cpu_start = time.perf_counter(), time.process_time()
    messages: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with cpu_time_limit(limit_s):
                loaded = load_session(copy.deepcopy(session) if isinstance(session, dict) else session)
                result = localize(loaded, **(options or {}))
                reasons = incomplete_reasons(loaded, result)
        except TimeLimitExceeded:
            return _timed(Outcome(1, f"stopped after {limit_s:g} CPU seconds", timed_out=True), start, cpu_start)
        except InputError as exc:
            return _timed(Outcome(2, str(exc), messages=_user_warnings(caught)), start, cpu_start)
        except Exception as exc:  # a bug of the method: recorded, counted as neither caught nor named
            return _timed(Outcome(1, f"{type(exc).__name__}: {exc}", crashed=True), start, cpu_start)
    for line in _user_warnings(caught) + list(result.warnings) + reasons:
        if line not in messages:
            messages.append(line)
    quality = getattr(result, "quality", None) or {}
    verdict = str(quality.get("verdict", NO_QUALITY_VERDICT))
    causes = [str(c.get("cause")) for c in quality.get("causes", []) if isinstance(c, dict)]
    strict = 1 if reasons or verdict != NO_QUALITY_VERDICT else 0
    outcome = Outcome(
        strict,
        messages=messages,
        verdict=verdict,
        causes=causes,
        positions=np.asarray(result.positions, dtype=float).reshape(-1, 3),
        covariances=[None if o.covariance is None else np.asarray(o.covariance, dtype=float) for o in result.objects],
    )
    return _timed(outcome, start, cpu_start)


def _timed(outcome: Outcome, start: float, cpu_start: float) -> Outcome:
    """``outcome`` with the wall-clock and CPU seconds since ``start`` and ``cpu_start``."""
    outcome.runtime_s = time.perf_counter() - start
    outcome.cpu_s = time.process_time() - cpu_start
    return outcome


@contextlib.contextmanager
def cpu_time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`~monovisual3d.budget.TimeLimitExceeded` in this thread once the process has used ``seconds`` of
    CPU time in the ``with`` block (None: no limit).

    CPU time rather than wall-clock time, so that a loaded machine does not stop runs that a quiet one finishes.
    A watchdog thread reads the process's CPU time every :data:`CPU_POLL_S` seconds and raises the exception in
    this thread (any thread: a Dask worker's too) at its next Python bytecode; a compiled kernel runs to its end
    first, as under ``SIGALRM``.
    """
    if seconds is None:
        yield
        return
    tid = ctypes.c_ulong(threading.get_ident())
    start = time.process_time()
    lock = threading.Lock()
    armed = [True]
    done = threading.Event()

    def watch() -> None:
        while not done.wait(CPU_POLL_S):
            if time.process_time() - start > seconds:
                with lock:
                    if armed[0]:
                        ctypes.pythonapi.PyThreadState_SetAsyncExc(tid, ctypes.py_object(TimeLimitExceeded))
                return

    watchdog = threading.Thread(target=watch, daemon=True)
    watchdog.start()
    try:
        yield
    finally:
        with lock:
            armed[0] = False
        done.set()
        ctypes.pythonapi.PyThreadState_SetAsyncExc(tid, ctypes.c_void_p(None))  # drop one raised but not yet delivered


def _user_warnings(caught: list[warnings.WarningMessage]) -> list[str]:
    """The warnings a user is shown about the input or the result (UserWarning and subclasses such as InputWarning)."""
    return [str(w.message) for w in caught if issubclass(w.category, UserWarning) and "numba" not in w.category.__module__]


def fruit_nees(outcome: Outcome, centres: NDArray[np.float64], radii: NDArray[np.float64]) -> list[float | None]:
    """NEES of each object paired with a true fruit (Hungarian, within the fruit's radius, at least :data:`MIN_GATE_M`).

    Returns
    -------
    list, one per pair: ``e^T C^-1 e`` (error ``e`` to the true centre, C the object's covariance), or None where the
    object has no covariance or one that is not symmetric positive definite
    """
    if not len(outcome.positions):
        return []
    ei, ti = match(outcome.positions, centres)
    out: list[float | None] = []
    for e, t in zip(ei, ti):
        err = outcome.positions[e] - centres[t]
        if np.linalg.norm(err) > max(float(radii[t]), MIN_GATE_M):
            continue
        C = outcome.covariances[e]
        out.append(float(err @ np.linalg.solve(C, err)) if C is not None and is_positive_definite(C) else None)
    return out


def covariance_counts(outcome: Outcome) -> dict[str, int]:
    """How many objects have no covariance, and how many one that is not symmetric positive definite."""
    return {
        "no_covariance": sum(C is None for C in outcome.covariances),
        "not_pd": sum(C is not None and not is_positive_definite(C) for C in outcome.covariances),
    }


def is_positive_definite(C: NDArray[np.float64]) -> bool:
    """Whether ``C`` (3, 3) is finite, symmetric and has only positive eigenvalues."""
    C = np.asarray(C, dtype=float)
    if C.shape != (3, 3) or not np.all(np.isfinite(C)) or not np.allclose(C, C.T, rtol=1e-6, atol=1e-18):
        return False
    return bool(np.linalg.eigvalsh(0.5 * (C + C.T)).min() > 0)


def mean_error_mm(outcome: Outcome, centres: NDArray[np.float64]) -> float | None:
    """Mean distance (mm) of the Hungarian pairs of objects and true fruit; None without an object."""
    if not len(outcome.positions):
        return None
    ei, ti = match(outcome.positions, centres)
    return float(np.mean(np.linalg.norm(outcome.positions[ei] - centres[ti], axis=1)) * 1e3)


def same_answer(outcome: Outcome, clean: Outcome) -> bool:
    """Whether ``outcome`` gives the clean answer: as many objects, each within :data:`SAME_ANSWER_M` of one."""
    if outcome.exit_code == 2 or len(outcome.positions) != len(clean.positions):
        return False
    if not len(clean.positions):
        return True
    ei, ti = match(outcome.positions, clean.positions)
    return bool(np.all(np.linalg.norm(outcome.positions[ei] - clean.positions[ti], axis=1) <= SAME_ANSWER_M))


def names_cause(outcome: Outcome, words: tuple[str, ...]) -> bool:
    """Whether a message (a warning, or the error of a refusal) contains one of ``words`` (case-insensitive)."""
    refusal = [outcome.error.lower()] if outcome.refused and outcome.error else []
    texts = [m.lower() for m in outcome.messages] + refusal
    return any(w.lower() in t for t in texts for w in words)


def score_session(
    outcome: Outcome, clean: Outcome, centres: NDArray[np.float64], radii: NDArray[np.float64], words: tuple[str, ...]
) -> dict[str, Any]:
    """What ``bench trust`` records of a mistaken session (plain JSON values).

    ``caught``: refused (exit 2), flagged (``--strict`` exit 1 with a message), or harmless: the clean answer within
    :data:`SAME_ANSWER_M`, every object paired with a fruit having a covariance with NEES under :data:`NEES_95`.
    """
    nees = fruit_nees(outcome, centres, radii)
    covered = all(v is not None and v < NEES_95 for v in nees)
    harmless = same_answer(outcome, clean) and covered
    return {
        "exit_code": outcome.exit_code,
        "refused": outcome.refused,
        "flagged": outcome.flagged,
        "harmless": harmless,
        "caught": outcome.refused or outcome.flagged or harmless,
        "named": names_cause(outcome, words),
        "crashed": outcome.crashed,
        "timed_out": outcome.timed_out,
        "verdict": outcome.verdict,
        "causes": outcome.causes,
        "error_mm": mean_error_mm(outcome, centres),
        "n_objects": len(outcome.positions),
        "nees": nees,
        **covariance_counts(outcome),
        "runtime_s": outcome.runtime_s,
        "cpu_s": outcome.cpu_s,
        "messages": outcome.messages,
        "error": outcome.error,
    }


def clean_record(outcome: Outcome, centres: NDArray[np.float64], radii: NDArray[np.float64]) -> dict[str, Any]:
    """What ``bench trust`` records of a clean session (plain JSON values): any alarm, the error, the NEES."""
    return {
        "exit_code": outcome.exit_code,
        "alarm": outcome.alarm,
        "crashed": outcome.crashed,
        "timed_out": outcome.timed_out,
        "verdict": outcome.verdict,
        "causes": outcome.causes,
        "error_mm": mean_error_mm(outcome, centres),
        "n_objects": len(outcome.positions),
        "nees": fruit_nees(outcome, centres, radii),
        **covariance_counts(outcome),
        "runtime_s": outcome.runtime_s,
        "cpu_s": outcome.cpu_s,
        "messages": outcome.messages,
        "error": outcome.error,
    }
