"""numba compile options of the shared kernels and of the ``paper`` engine: fast-math flags, on-disk cache."""

from __future__ import annotations

#: LLVM fast-math flags used: reassociation (vectorised reductions), contraction (FMA),
#: reciprocal and approximate functions, no signed zeros. Not ``nnan``/``ninf``: the log
#: variant stores -inf and the code relies on comparisons with it.
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}

#: ``numba.njit`` keywords of every kernel compiled with :data:`FASTMATH`: cached on disk, the GIL released.
NJIT_OPTIONS = {"cache": True, "fastmath": FASTMATH, "nogil": True}
