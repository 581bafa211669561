"""Benchmarks: reusable measurements behind ``monovisual3d bench ...``, also used by the one-off studies of the
repository's ``experiments/`` folder."""
