"""Hostile but well-formed input: the built-in example session with its boxes replaced by random ones.

Every view of the example (3 views, 640 x 480) gets N random boxes of 10-80 px per side; random boxes are the
default method's worst case (every triple of boxes whose cones meet in space is an object). Prints the wall time of
one ``localize`` call, the objects found and the result's stage timings. Above ``limits.MAX_BAYES_BOXES_PER_VIEW``
boxes a view is refused with one line before any work.

    python experiments/random_boxes.py 300          # N = 300, seed 0
    python experiments/random_boxes.py 100 --seed 3
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from monovisual3d import load_session
from monovisual3d.api import localize
from monovisual3d.errors import InputError
from monovisual3d.examples import example_session_path

#: Side lengths of the random boxes, pixels.
SIDE_PX = (10.0, 80.0)


def random_session(n_boxes: int, seed: int) -> dict:
    """The example session (as JSON data) with ``n_boxes`` random boxes in each view."""
    data = json.loads(example_session_path().read_text())
    rng = np.random.default_rng(seed)
    w, h = data["camera"]["width"], data["camera"]["height"]
    for view in data["views"]:
        corner = rng.uniform(0, [w - SIDE_PX[1], h - SIDE_PX[1]], size=(n_boxes, 2))
        side = rng.uniform(*SIDE_PX, size=(n_boxes, 2))
        boxes = np.hstack([corner, corner + side])  # bbox_xyxy, pixels
        view["detections"] = [{"bbox_xyxy": b} for b in boxes.tolist()]
    return data


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n_boxes", type=int, help="random boxes per view")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    t0 = time.perf_counter()
    try:
        result = localize(load_session(random_session(args.n_boxes, args.seed)))
    except InputError as exc:
        print(f"{args.n_boxes} boxes/view: refused after {time.perf_counter() - t0:.1f} s: {exc}")
        return
    stages = {k: round(v, 1) for k, v in result.timing_s.items()}
    print(f"{args.n_boxes} boxes/view: {time.perf_counter() - t0:.1f} s, {len(result.objects)} objects, stages (s) {stages}")


if __name__ == "__main__":
    main()
