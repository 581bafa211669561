"""Settings and scalar helpers of the engine's numba kernels: classification margin, ``exp(-q)`` in float64 and float32.

Part of the kernels re-exported by :mod:`monovisual3d.methods.paper.engine.numba_kernels` (see its docstring for the design).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from ....kernels.flags import NJIT_OPTIONS

#: Margin (pixels) of the tile/box classification, far above float64 rounding of pixel coordinates.
CLASSIFY_MARGIN_PX = 1e-6
#: Largest argument of :func:`exp_neg` (larger q are clamped; callers cut at q_cut < 43).
EXP_NEG_MAX = 43.0

# Taylor coefficients of exp(-s) around 0, s = q / 64 - 0.3375 in [-0.3375, 0.3375].
_EXP_C = math.exp(-0.3375)


@njit(**NJIT_OPTIONS)
def exp_neg(q):  # pragma: no cover - compiled
    """``exp(-q)`` for ``0 <= q <= 43``, branch free, relative error < 1e-12.

    Scaling and squaring: ``exp(-q) = (exp(-0.3375) * exp(-s)) ** 64`` with
    ``s = q / 64 - 0.3375`` in ``[-0.3375, 0.3375]`` and a degree-11 Taylor
    polynomial for ``exp(-s)`` (truncation 5e-15, times 64 after the squarings).
    Written without calls so that loops using it vectorise without SVML.
    """
    s = -(q * 0.015625 - 0.3375)
    p = 2.505210838544172e-08
    p = p * s + 2.755731922398589e-07
    p = p * s + 2.7557319223985893e-06
    p = p * s + 2.48015873015873e-05
    p = p * s + 0.0001984126984126984
    p = p * s + 0.001388888888888889
    p = p * s + 0.008333333333333333
    p = p * s + 0.041666666666666664
    p = p * s + 0.16666666666666666
    p = p * s + 0.5
    p = p * s + 1.0
    p = p * s + 1.0
    y = p * _EXP_C
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    return y


@intrinsic
def _pow2_from_biased(typingctx, f):  # pragma: no cover - compiled
    """``2**n`` from ``f = (n + 127) * 2**23`` (float32): convert to int32 and reinterpret the bits."""
    if f != types.float32:
        return None
    sig = types.float32(types.float32)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(builder.fptosi(args[0], ir.IntType(32)), ir.FloatType())

    return sig, codegen


_F = np.float32


@njit(**NJIT_OPTIONS)
def exp_neg32(q):  # pragma: no cover - compiled
    """``exp(-q)`` in float32 for ``0 <= q <= 87`` (Cephes ``expf``), relative error < 2e-7, branch free."""
    x = -q
    n = np.floor(x * _F(1.4426950408889634) + _F(0.5))
    r = x - n * _F(0.693359375) - n * _F(-2.12194440e-4)
    p = _F(1.9875691500e-4)
    p = p * r + _F(1.3981999507e-3)
    p = p * r + _F(8.3334519073e-3)
    p = p * r + _F(4.1665795894e-2)
    p = p * r + _F(1.6666665459e-1)
    p = p * r + _F(5.0000001201e-1)
    y = p * r * r + r + _F(1.0)
    return y * _pow2_from_biased((n + _F(127.0)) * _F(8388608.0))
