"""A vectorisable ``exp`` for the compiled 2D-field kernels.

numba's ``math.exp`` calls libm once per element, which LLVM cannot vectorise without Intel's SVML (absent
here), so a 200×200 image over 720 obstacle points (28.8 M exponentials) took ~160 ms. This version uses only
arithmetic and one integer→float bit cast, so the obstacle loop vectorises (~10× faster).

Method (Cody & Waite 1980; Muller, *Elementary Functions*, 3rd ed., §11.3): write
``x = k·ln 2 + r`` with ``k = round(x / ln 2)`` and ``|r| ≤ ln(2)/2``, ``ln 2`` split in a high and a low
part so ``r`` is exact to double precision; ``exp(r)`` by its degree-12 Taylor polynomial (truncation
``|r|^13/13! < 2e-16``); ``2^k`` assembled directly in the IEEE-754 exponent field. Measured relative error
≤ 3.4e-16 on [−700, 700]. Inputs are clipped to [−700, 700]: ``exp(−700) ≈ 1e−304`` stands for underflow, and
callers keep their exponents far below +700 (parameter validation).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

_LOG2E = 1.4426950408889634
_LN2_HI = 0.6931471803691238
_LN2_LO = 1.9082149292705877e-10
_EXP_CLIP = 700.0


@intrinsic
def _int64_bits_as_float64(typingctx, bits):  # type: ignore[no-untyped-def]
    """Reinterpret the 64 bits of an int64 as a float64 (no conversion)."""
    signature = types.float64(types.int64)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(args[0], ir.DoubleType())

    return signature, codegen


@njit(cache=True, inline="always")
def fast_exp(x: float) -> float:
    """``exp(x)`` to ~1 ulp for ``x`` in [−700, 700] (clipped outside), branch-free and vectorisable."""
    x = min(max(x, -_EXP_CLIP), _EXP_CLIP)
    k = math.floor(x * _LOG2E + 0.5)
    r = x - k * _LN2_HI - k * _LN2_LO
    p = 1.0 + r * (1.0 + r * (1.0 / 2 + r * (1.0 / 6 + r * (1.0 / 24 + r * (1.0 / 120 + r * (
        1.0 / 720 + r * (1.0 / 5040 + r * (1.0 / 40320 + r * (1.0 / 362880 + r * (
            1.0 / 3628800 + r * (1.0 / 39916800 + r * (1.0 / 479001600))))))))))))
    two_k: float = _int64_bits_as_float64((np.int64(k) + 1023) << 52)  # type: ignore[call-arg]
    return p * two_k
