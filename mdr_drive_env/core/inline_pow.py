"""``x ** y`` for ``x > 0`` as inline arithmetic, for the fast kernel's per-step contact radius.

A call to the C library's ``pow`` inside a compiled loop costs more than the call: the vector
registers of the loop around it are saved and restored, and the loop cannot be vectorised
(docs/performance.md). :func:`pow_positive` is
``exp(y log x)`` with fdlibm's polynomials for ``log`` and ``exp`` (Sun Microsystems, 1993; the
same coefficients as glibc's and musl's scalar fallbacks) and bit-level range reduction, all
inlined; its relative error is a few units in the last place for the arguments the kernel passes
(``tests/test_inline_pow.py``), far below the solver's discretisation error.
"""

from __future__ import annotations

from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00
_SQRT2 = 1.4142135623730951
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01
_P1 = 1.66666666666666019037e-01
_P2 = -2.77777777770155933842e-03
_P3 = 6.61375632143793436117e-05
_P4 = -1.65339022054652515390e-06
_P5 = 4.13813679705723846039e-08
_MANTISSA = (1 << 52) - 1
_ONE_BITS = 1023 << 52


@intrinsic
def _bits(typingctx, x):
    """The IEEE-754 bits of a float64 as an int64 (a register move)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _from_bits(typingctx, b):
    """The float64 whose IEEE-754 bits are the int64 ``b``."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@njit(cache=True, inline="always", error_model="numpy")
def log_positive(x):
    """Natural log of a normal, finite ``x > 0`` (fdlibm's ``__ieee754_log`` scheme)."""
    b = _bits(x)
    e = (b >> 52) - 1023
    m = _from_bits((b & _MANTISSA) | _ONE_BITS)  # in [1, 2)
    if m > _SQRT2:
        m *= 0.5
        e += 1
    f = m - 1.0
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    r = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7))) + w * (_LG2 + w * (_LG4 + w * _LG6))
    hfsq = 0.5 * f * f
    return e * _LN2_HI - ((hfsq - (s * (hfsq + r) + e * _LN2_LO)) - f)


@njit(cache=True, inline="always", error_model="numpy")
def exp_moderate(y):
    """``exp(y)`` for ``|y| < 700`` (fdlibm's ``__ieee754_exp`` scheme, no overflow handling)."""
    n = int(y * _INV_LN2 + (0.5 if y >= 0.0 else -0.5))
    hi = y - n * _LN2_HI
    lo = n * _LN2_LO
    r = hi - lo
    t = r * r
    c = r - t * (_P1 + t * (_P2 + t * (_P3 + t * (_P4 + t * _P5))))
    v = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi)
    return v * _from_bits((n + 1023) << 52)


@njit(cache=True, inline="always", error_model="numpy")
def pow_positive(x, y):
    """``x ** y`` for a normal, finite ``x > 0`` and ``|y log x| < 700``, inline."""
    return exp_moderate(y * log_positive(x))
