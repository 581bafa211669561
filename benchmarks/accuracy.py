"""Accuracy benchmark (issue 4): run with `python benchmarks/accuracy.py [--quick] [--output results.json]`.

Same as `monovisual3d bench accuracy`; the logic lives in monovisual3d.bench.accuracy.
"""

from __future__ import annotations

import argparse

from monovisual3d.bench.accuracy import format_markdown, run_accuracy, save


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer seeds and conditions (seconds)")
    parser.add_argument("--output", default=None, help="write the results as JSON here")
    parser.add_argument("--methods", default="bayes,bayes+masks,paper", help="comma-separated methods")
    args = parser.parse_args()
    results = run_accuracy(quick=args.quick, methods=tuple(args.methods.split(",")), progress=lambda msg: print(msg, flush=True))
    print(format_markdown(results))
    if args.output:
        save(results, args.output)


if __name__ == "__main__":
    main()
