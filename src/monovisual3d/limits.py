"""Documented limits of the input files (sessions, truth/result files, imported data).

One module owns them, so the loaders, the readers of :mod:`monovisual3d.io`, the
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
#: Most views in a session.
MAX_VIEWS = 100_000
#: Most detections in one view.
MAX_DETECTIONS_PER_VIEW = 10_000
#: Most points of a mask polygon.
MAX_POLYGON_POINTS = 100_000
#: Mask polygon vertices may lie this many image sizes outside the image (the outline of a clipped object).
POLYGON_MARGIN_IMAGES = 1.0
#: Length of a value's excerpt quoted in an error message, characters.
EXCERPT_CHARS = 60

#: Default manipulator reach R (metres); the paper's grid is a cube of side 2R.
DEFAULT_REACH_M = 0.6

#: Relative posterior threshold of the cells the paper's k-means clusters (:mod:`monovisual3d.estimation`).
DEFAULT_KEEP_THRESHOLD = 0.1
#: Largest dense grid by default, bytes: the default ``max_memory`` (2 GiB) of every method.
DEFAULT_MAX_BYTES = 2 * 1024**3
