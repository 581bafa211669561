"""Speed benchmark (issue 5): run with `python benchmarks/speed.py [--quick] [--output results.json]`.

Same as `monovisual3d bench speed`; the logic lives in monovisual3d.bench.speed.
"""

from __future__ import annotations

import argparse

from monovisual3d.bench.speed import format_markdown, run_speed
from monovisual3d.bench.timing import write_json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small grids, two repetitions (seconds)")
    parser.add_argument("--output", default=None, help="write the results as JSON here")
    parser.add_argument("--edges", default=None, help="cells per grid axis, comma separated (default 63,126,252)")
    parser.add_argument("--device", default=None, help="torch device (default cuda when available)")
    args = parser.parse_args()
    edges = tuple(int(e) for e in args.edges.split(",")) if args.edges else None
    result = run_speed(quick=args.quick, edges=edges, torch_device=args.device, progress=lambda msg: print(msg, flush=True))
    print(format_markdown(result))
    if args.output:
        write_json(result, args.output)


if __name__ == "__main__":
    main()
