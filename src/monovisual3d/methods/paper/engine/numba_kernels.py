"""Fused, parallel numba kernels of the histogram update (the fast twin of methods/paper/kernels.py and filter.py).

The readable numpy reference is :func:`monovisual3d.methods.paper.filter.paper_view_likelihood_grid`
with :func:`monovisual3d.methods.paper.filter.paper_update`; tests in ``tests/methods/paper/engine`` compare the
two. Nothing here builds an N x 3 array of cell centres: centres come from the
cell indices inside the loops.

How the dense update works
--------------------------
The grid is cut into tiles (default 4 x 4 x 32 cells, k contiguous). For each
tile and view:

1. The tile's extreme cell centres are projected. A pinhole projection maps
   the convex hull of the tile to the convex hull of the projected corners
   (all corners in front of the camera), so the bounding rectangle of the
   corners bounds every cell of the tile in normalised coordinates. Lens
   distortion is bounded with interval arithmetic, which stays conservative
   even where the distortion polynomial folds over.
2. Each box is classified against that rectangle: *outside* its support
   (skipped, exactly zero for the square kernel, below ``gauss_eps`` for the
   Gaussian), *inside* (square kernel only: contributes exactly 1 to every
   cell) or *partial* (evaluated per cell).
3. A tile whose prior is zero is skipped; a tile no box reaches is zeroed; a
   tile covered only by inside boxes is multiplied by a constant; only the
   other tiles are evaluated per cell, in rows along k written so that LLVM
   can vectorise them (branch-free projection, a branch-free ``exp``).

The posterior multiply and the per-tile sums are done in the same pass. The
maximum normalisation of the paper (Eq. 5) cancels in the final normalisation
(``prior * L / m / sum(prior * L / m) = prior * L / sum(prior * L)``), so no
second pass over the likelihood is needed; the caller normalises lazily by
passing ``in_scale`` (linear storage: 1 / previous sum) to the next call. Per-tile partial sums are added in a fixed order, so the results do
not depend on the number of threads.

Accuracy
--------
Geometry and kernels are evaluated in float64; storage may be float32. The
Gaussian cut-off under-estimates each cell's likelihood by less than
``gauss_eps`` (see :mod:`monovisual3d.methods.paper.engine.params`). :func:`exp_neg` has a
relative error below 1e-12 on its range.

All kernels are compiled with ``cache=True``; the first call in a fresh
environment compiles them (tens of seconds for all type signatures), later
processes load the cache.

The kernels live in modules by concept, all re-exported here:

- :mod:`._common`: :func:`exp_neg` / :func:`exp_neg32`, the classification margin;
- :mod:`._interval`: interval arithmetic, :func:`pixel_bounds`, :func:`box_upper`;
- :mod:`._mixture`: the box kernels over rows of pixels and at points;
- :mod:`._dense`: :func:`dense_update` and the normalisation passes;
- :mod:`._octree`: :func:`octree_eval` of the sparse path.

They project through the kernels shared with the other methods, :mod:`monovisual3d.kernels.project`
(:func:`~monovisual3d.kernels.project.distort_xy`, the one compiled distortion, the row and point projections),
and compile with :data:`monovisual3d.kernels.flags.NJIT_OPTIONS`.

Parallel entry points (:func:`dense_update`, :func:`scale_inplace`, :func:`exp_shift`,
:func:`octree_eval`) are called through :mod:`monovisual3d.kernels.threads`, which picks the thread
count by the amount of work.
"""

from __future__ import annotations

from ._common import CLASSIFY_MARGIN_PX, EXP_NEG_MAX, exp_neg, exp_neg32  # noqa: F401
from ._dense import TILES_PER_TASK, dense_update, exp_shift, scale_inplace  # noqa: F401
from ._interval import _imul, _ipoly, _iscale, _isq, box_upper, distort_bounds, pixel_bounds  # noqa: F401
from ._mixture import add_box_row, add_box_upper_row, add_gauss_row32, box_point, mixture_point  # noqa: F401
from ._octree import OCTREE_CHUNK, octree_eval  # noqa: F401
