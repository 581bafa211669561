"""Documented limits of the input files (sessions, truth/result files, imported data).

Numbers only: the checks that apply them live in :mod:`monovisual3d.checks`. Numpy-free: the
CLI's ``--help`` imports it.

One module owns the limits, so the loaders, the readers of :mod:`monovisual3d.io`, the
error messages and the documentation agree. Inputs beyond a limit are refused
with a one-line :class:`~monovisual3d.errors.InputError` that names the file and
the field, never by running out of memory or time.
"""

from __future__ import annotations

#: Files larger than this are refused, bytes (a JSON file takes up to ~25 times its size in memory once parsed).
MAX_FILE_BYTES = 64 * 1024 * 1024
#: YAML files larger than this are refused, bytes (YAML is parsed in pure Python: use JSON for big sessions).
MAX_YAML_BYTES = 2 * 1024 * 1024
#: Most values in a YAML file before aliases are expanded (parsing time grows with them).
MAX_YAML_NODES = 100_000
#: Deepest nesting of lists/objects in a JSON or YAML file (a session needs 6).
MAX_NESTING = 64
#: Most values (list items, object members and scalars, aliases expanded) in one JSON or YAML file.
MAX_NODES = 5_000_000
#: Largest accepted |coordinate| of a position (views, workspace, objects), metres.
MAX_ABS_POSITION_M = 1e6
#: Largest accepted |time stamp|, seconds (epoch times are ~1.7e9).
MAX_ABS_STAMP_S = 1e12
#: Largest accepted |angle| (rotation vector norm, roll/pitch/yaw), radians.
MAX_ABS_ANGLE_RAD = 1e3
#: Largest image side, pixels.
MAX_IMAGE_SIDE = 32768
#: Largest image, pixels (width * height): 2**26, e.g. 8192 x 8192; an RLE mask decodes to this many bytes.
MAX_IMAGE_PIXELS = 2**26
#: Largest |intrinsic| (fx, fy, cx, cy), pixels.
MAX_ABS_INTRINSIC_PX = 1e7
#: Largest |distortion coefficient|.
MAX_ABS_DISTORTION = 1e6
#: Most views in a session (an hour of robot scanning at 3 views a second; the paper uses 3).
MAX_VIEWS = 10_000
#: Most detections in one view (a dense plant row shows 50-100 fruit; far above real use).
MAX_DETECTIONS_PER_VIEW = 2_000
#: Most points of a mask polygon.
MAX_POLYGON_POINTS = 100_000
#: Mask polygon vertices may lie this many image sizes outside the image (the outline of a clipped object).
POLYGON_MARGIN_IMAGES = 1.0
#: Length of a value's excerpt quoted in an error message, characters.
EXCERPT_CHARS = 60

#: Default manipulator reach R (metres); the paper's grid is a cube of side 2R.
DEFAULT_REACH_M = 0.6

#: Relative posterior threshold of the cells the paper's k-means clusters (:mod:`monovisual3d.methods.paper.kmeans`).
DEFAULT_KEEP_THRESHOLD = 0.1
#: Largest dense grid by default, bytes: the default ``max_memory`` (2 GiB) of every method.
DEFAULT_MAX_BYTES = 2 * 1024**3
#: Smallest memory budget accepted, bytes (below this nothing useful fits).
MIN_MAX_MEMORY = 16 * 1024**2
#: Largest byte count :func:`~monovisual3d.checks.parse_bytes` returns (an int64 with room to spare).
MAX_PARSED_BYTES = 2**62
#: Byte-size suffixes (lower case) and their multipliers: SI (k, MB, ...) and binary (KiB, MiB, ...).
BYTE_UNITS = {
    "": 1,
    "b": 1,
    "k": 1000,
    "kb": 1000,
    "kib": 1024,
    "m": 1000**2,
    "mb": 1000**2,
    "mib": 1024**2,
    "g": 1000**3,
    "gb": 1000**3,
    "gib": 1024**3,
    "t": 1000**4,
    "tb": 1000**4,
    "tib": 1024**4,
}


# ---------------------------------------------------------------------- work limits of the commands (issue 23)
# Options that set how much work a command does are bounded here, so a typo such as
# ``--false-positives 1e9`` is a one-line error naming the option and its limit, not
# minutes of work or a MemoryError. Each is set far above real use.

#: Most candidate poses of ``next-view`` (``cap:N`` or a candidate file); the planner holds ~30 KB per candidate.
MAX_CANDIDATES = 5_000
#: Most views ``simulate`` generates (``ring:N``, ``hemisphere:N``, a pose file, ``--active N``): ~40 ms each.
MAX_SIM_VIEWS = 500
#: Most views of ``simulate --active N`` (each step localises every view so far and plans: 12 views took 9 s of CPU).
MAX_ACTIVE_VIEWS = 20
#: Most rays ``simulate`` casts in one run: views x width x height x supersample**2 (500 views of 640 x 480).
MAX_SIM_RAYS = 500 * 640 * 480
#: Most view pictures (``--images``) ``simulate`` draws in one run (~0.2 s each with matplotlib).
MAX_SIM_PICTURES = 100
#: Most fruit of a generated ``simulate`` scene (``--n-fruit``).
MAX_SIM_FRUIT = 1_000
#: Largest expected number of simulated false-positive boxes per image (``--false-positives``).
MAX_SIM_FALSE_POSITIVES = 100.0
#: Largest simulated camera position error, millimetres (``--pose-error-mm``): 1 m.
MAX_SIM_POSE_ERROR_MM = 1000.0
#: Largest simulated camera rotation error, degrees (``--pose-error-deg``).
MAX_SIM_POSE_ERROR_DEG = 180.0
#: Largest seed accepted by ``simulate`` and the benchmarks (numpy's seeds are non-negative, below 2**128).
MAX_SEED = 2**63 - 1
#: Most data rows of one imported pose or detection table (a 30 fps video of an hour is 108,000 frames).
MAX_TABLE_ROWS = 200_000
#: Largest ``--time-limit``, seconds (one day); the option's default is no limit.
MAX_TIME_LIMIT_S = 86_400.0
#: Finest ``resolution`` of the ``bayes`` search, metres: each halving below it adds a search level of up to
#: the hypothesis cap (0.1 mm took over 70 s on the one-sphere example); the continuous refinement, not
#: the grid, gives the accuracy, so finer cells buy nothing.
MIN_SEARCH_RESOLUTION_M = 1e-3
#: Largest k-means of the ``paper`` method: clusters x clustered cells (distances per iteration). 50 clusters over
#: 1 M cells; 1,000 boxes per view ask for 1,000 clusters, which took minutes before this limit.
MAX_KMEANS_WORK = 50_000_000
#: Most local worker processes a batch or a benchmark starts (``--workers``); each loads the package (~200 MB).
MAX_LOCAL_WORKERS = 256
#: Most boxes in one view the ``bayes`` search takes on (estimated before any work: a session beyond it is refused
#: with a one-line error naming this limit). Random boxes are its worst case: every triple of them that meets in
#: space is an object (30 x 30 px boxes in the example's 3 views: 95 objects at 100 per view, 1,067 at 1,000). On
#: this project's 2-core test machine (2026-12-02, tile index) they took 3.8 s at 100 per view, 10 s at 200, 17 s
#: at 300 and 159 s at 1,000; 10-80 px random boxes, 44 s at 300 (220 objects). A dense plant row (96 fruit from
#: 0.8 m) has about 90 per view (1.1-1.4 s), so the limit is over three times real use.
MAX_BAYES_BOXES_PER_VIEW = 300
#: Most views with boxes the ``bayes`` method takes in one session. Its search, extraction and refits grow with
#: the views: on this project's 2-core machine a ring of views of the paper's six fruit took about 10 s at 50
#: views, 14 s at 100 and 30 s (2.3 GB) at 200; 500 did not finish in 120 s. Robots use 3-20 views (the active
#: loop stops by 20), so the limit is ten times real use.
MAX_BAYES_VIEWS = 200
