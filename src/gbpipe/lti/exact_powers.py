"""Matrix powers correct to the last bit of ``np.longdouble``, by integer arithmetic.

The chain ``A^(k+1) = A A^k`` in floating point loses digits where its products cancel:
an entry of ``A A^k`` far smaller than the same entry of ``|A| |A^k|`` (the transient
growth of a strongly non-normal ``A``, e.g. eigenvector condition 1e6 with ``||A||`` of
1e4 and ``||A^k||`` of 1e5) keeps only the digits the cancellation left. Here every
matrix is an integer matrix times a power of two (fixed point, ``_BITS`` bits below the
largest entry): Python's unbounded integers multiply and add exactly (numpy object
arrays), and each product is truncated once to ``_BITS`` bits. The truncation, 2^-160 of
the largest entry, stays far below the 2^-64 rounding of ``np.longdouble`` even after a
cancellation by 2^90, so the powers are the exact powers of ``A``, rounded once.

Used by :mod:`gbpipe.lti.simulation` for the systems whose powers cancel.
"""

from __future__ import annotations

import numpy as np

__all__ = ["exact_powers"]

# Bits kept below the largest entry of each power (see the module docstring).
_BITS = 160
# Significand bits of a long double (x87 extended: 64; where long double is the float64
# itself, 53): the conversions below keep exactly this many bits.
_MANT = int(np.finfo(np.longdouble).nmant) + 1
_HALF = 1 << 32


def _to_fixed(a: np.ndarray) -> tuple[np.ndarray, int]:
    """``(M, s)`` with ``a = M 2^-s`` exactly, ``M`` an object array of Python ints."""
    mant, expo = np.frexp(np.asarray(a, dtype=np.longdouble))
    top = int(expo.max()) if np.any(mant) else 0
    s = _BITS - top
    ints = np.empty(a.shape, dtype=object)
    for idx, (m, e) in enumerate(zip(mant.flat, expo.flat, strict=True)):
        # m 2^MANT is an integer (the significand); int() of a long double is exact
        v = int(np.ldexp(m, _MANT))
        shift = int(e) - _MANT + s
        # entries below 2^-_BITS of the largest are truncated: far below any rounding
        ints.flat[idx] = v << shift if shift >= 0 else v >> -shift
    return ints, s


def _to_longdouble(ints: np.ndarray, s: int) -> np.ndarray:
    """``ints 2^-s`` as ``np.longdouble``, each entry truncated to its _MANT top bits."""
    out = np.empty(ints.shape, dtype=np.longdouble)
    for idx, v in enumerate(ints.flat):
        mag = abs(int(v))
        drop = max(mag.bit_length() - _MANT, 0)
        q = mag >> drop
        # np.longdouble(int) goes through float64 (53 bits): assemble two exact halves
        val = np.longdouble(q // _HALF) * _HALF + np.longdouble(q % _HALF)
        out.flat[idx] = np.ldexp(-val if v < 0 else val, drop - s)
    return out


def exact_powers(a: np.ndarray, count: int) -> np.ndarray:
    """``a^0 .. a^count`` exact, rounded once to ``np.longdouble``.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Square matrix (float64 or longdouble; its value is taken exactly).
    count : int
        Highest power.

    Returns
    -------
    ndarray of np.longdouble, shape (count + 1, n, n)
        The powers; each entry carries the long double rounding (truncation) of the
        exact power, plus at most 2^-160 of the largest entry times the cancellation.
    """
    n = a.shape[0]
    m, s_a = _to_fixed(a)
    p = np.empty((n, n), dtype=object)
    p[...] = 0
    for i in range(n):
        p[i, i] = 1 << _BITS
    s_p = _BITS
    powers = np.empty((count + 1, n, n), dtype=np.longdouble)
    powers[0] = np.eye(n)
    for k in range(1, count + 1):
        p = m @ p  # exact: Python ints
        s_p += s_a
        size = max(abs(int(v)).bit_length() for v in p.flat)
        drop = max(size - _BITS, 0)
        if drop:  # floor of p 2^-drop: an error below one unit of 2^-_BITS
            p = p >> drop
            s_p -= drop
        powers[k] = _to_longdouble(p, s_p)
    return powers
