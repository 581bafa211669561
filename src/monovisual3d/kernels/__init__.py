"""Compiled kernels shared by the methods: camera projection and distortion, compile flags, thread policy.

- :mod:`.project`: :func:`~.project.distort_xy`, the one compiled lens distortion (the ``paper`` engine and
  the ``bayes`` kernels distort through it), and the projections of grid cells and points to pixels;
- :mod:`.flags`: the numba compile options (fast-math flags, on-disk cache) of those kernels;
- :mod:`.threads`: how many threads a parallel kernel gets, by its amount of work (``--threads``).

A kernel that one method alone uses lives in that method (``methods/paper/engine/``,
``methods/bayes/_kernels.py``).
"""
