"""How often does each input check fire, on clean sessions and on each integration mistake?

The session-level input checks (:func:`monovisual3d.session.diagnose.check_session`, with the loader's tests of the
boxes as written) are run alone, without a method, on the clean sessions of ``bench trust``
(:func:`monovisual3d.bench.trust_cases.make_case`: paper, greenhouse, arc and row families at 2, 5 and 10 % box noise)
and on every mistake of :mod:`monovisual3d.sim.mistakes` made on one noise level per seed and family (as ``bench trust``
makes them). Printed per mistake: sessions, refused (InputError), flagged (a cause), named (a refusal or cause message
containing the mistake's words), the right cause ID, and other cause IDs; and the clean sessions with any cause, each
listed. ``monovisual3d bench trust`` scores the same mistakes through the whole ``localize --strict`` path.

Usage: python experiments/input_checks.py [FIRST LAST] [--mistakes NAME,...]   (default: seeds 0-3, every mistake)
"""

from __future__ import annotations

import argparse
import collections
import warnings

from monovisual3d.bench.trust_cases import BOX_NOISES, FAMILIES, make_case
from monovisual3d.errors import InputError
from monovisual3d.session.diagnose import check_session
from monovisual3d.session.load import session_from_dict
from monovisual3d.sim.mistakes import MISTAKES, applies, make_mistake


def measure(seeds: range, mistakes: list[str]) -> tuple[int, list[str], dict[str, collections.Counter]]:
    """Clean sessions run, the clean sessions with a cause (described), and per mistake its counts."""
    n_clean, alarms = 0, []
    counts: dict[str, collections.Counter] = {m: collections.Counter() for m in mistakes}
    for family in FAMILIES:
        for seed in seeds:
            for sigma in BOX_NOISES:
                case = make_case(family, seed, sigma)
                causes = check_session(session_from_dict(case.session.to_dict()))[1]
                n_clean += 1
                if causes:
                    alarms.append(f"{family} seed {seed} noise {sigma:g}: " + " | ".join(c.message for c in causes))
                if sigma != BOX_NOISES[seed % len(BOX_NOISES)]:
                    continue
                for name in mistakes:
                    if applies(MISTAKES[name], case.inputs()):
                        _score(counts[name], name, make_mistake(name, case.inputs(), rng=seed))
    return n_clean, alarms, counts


def _score(c: collections.Counter, name: str, mistaken) -> None:  # type: ignore[no-untyped-def]
    c["sessions"] += 1
    try:
        causes = check_session(session_from_dict(mistaken.session))[1]
        texts, ids = [x.message for x in causes], {x.cause for x in causes}
        c["flagged"] += bool(causes)
    except InputError as exc:
        texts, ids = [str(exc)], set()
        c["refused"] += 1
    c["named"] += any(w.lower() in t.lower() for t in texts for w in mistaken.words)
    c["right_id"] += MISTAKES[name].cause in ids
    for other in sorted(ids - {MISTAKES[name].cause}):
        c["other:" + other] += 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", nargs="?", type=int, default=0)
    parser.add_argument("last", nargs="?", type=int, default=4, help="seeds first..last-1")
    parser.add_argument("--mistakes", default=",".join(MISTAKES), help="comma separated (default every mistake)")
    args = parser.parse_args()
    mistakes = [m for m in args.mistakes.split(",") if m]
    warnings.simplefilter("ignore")  # the loader's per-box warnings; the causes are what is counted
    n_clean, alarms, counts = measure(range(args.first, args.last), mistakes)
    print(f"clean sessions: {n_clean}, with a cause: {len(alarms)}")
    for line in alarms:
        print("  " + line)
    print(f"{'mistake':24s} sessions refused flagged named right_id  other")
    for name, c in counts.items():
        other = ", ".join(f"{k[6:]} {v}" for k, v in c.items() if k.startswith("other:"))
        print(f"{name:24s} {c['sessions']:8d} {c['refused']:7d} {c['flagged']:7d} {c['named']:5d} {c['right_id']:8d}  {other}")


if __name__ == "__main__":
    main()
