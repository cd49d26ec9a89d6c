"""Matrix powers and Krylov products correct to the last bit of ``np.longdouble``, by
integer arithmetic.

The chain ``A^(k+1) = A A^k`` in floating point loses digits where its products cancel:
an entry of ``A A^k`` far smaller than the same entry of ``|A| |A^k|`` (the transient
growth of a strongly non-normal ``A``, e.g. eigenvector condition 1e6 with ``||A||`` of
1e4 and ``||A^k||`` of 1e5) keeps only the digits the cancellation left. Here every
matrix is an integer matrix times a power of two (fixed point, ``_BITS`` bits below the
largest entry): Python's unbounded integers multiply and add exactly (numpy object
arrays), and each product is truncated once to ``_BITS`` bits. The truncation, 2^-160 of
the largest entry, stays far below the 2^-64 rounding of ``np.longdouble`` even after a
cancellation by 2^90, so the results are the exact ones, rounded once.

Used by :mod:`gbpipe.lti.simulation` for the systems whose powers cancel.
"""

from __future__ import annotations

import numpy as np

__all__ = ["exact_krylov", "exact_power"]

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


def _product(x: tuple[np.ndarray, int], y: tuple[np.ndarray, int]) -> tuple[np.ndarray, int]:
    """Exact product of two fixed-point matrices, truncated to _BITS bits (relative to
    the largest entry of the product)."""
    p = x[0] @ y[0]  # exact: Python ints
    s_p = x[1] + y[1]
    drop = max(max(abs(int(v)).bit_length() for v in p.flat) - _BITS, 0)
    # floor of p 2^-drop: an error below one unit of 2^-_BITS of the largest entry
    return (p >> drop, s_p - drop) if drop else (p, s_p)


def exact_power(a: np.ndarray, k: int) -> np.ndarray:
    """``a^k`` exact, rounded once to ``np.longdouble`` (binary powering: about
    2 log2(k) exact products of n^3 integer operations each).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Square matrix (float64 or longdouble; its value is taken exactly).
    k : int
        Power, >= 1.

    Returns
    -------
    ndarray of np.longdouble, shape (n, n)
        The power, truncated to long double; besides that truncation, at most 2^-160 of
        the largest entry per product times the cancellation of the products.
    """
    base = _to_fixed(a)
    result = None
    while True:
        if k & 1:
            result = base if result is None else _product(result, base)
        k >>= 1
        if not k:
            return _to_longdouble(*result)
        base = _product(base, base)


def exact_krylov(a: np.ndarray, b: np.ndarray, count: int) -> np.ndarray:
    """``b, a b, .., a^count b`` exact, each rounded once to ``np.longdouble``.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Square matrix (float64 or longdouble; its value is taken exactly).
    b : ndarray, shape (n, m)
        Matrix the powers multiply.
    count : int
        Highest power, >= 0.

    Returns
    -------
    ndarray of np.longdouble, shape (count + 1, n, m)
        The products (n^2 m integer operations each, not the n^3 of a power).
    """
    a_fixed, term = _to_fixed(a), _to_fixed(b)
    out = np.empty((count + 1, *b.shape), dtype=np.longdouble)
    out[0] = np.asarray(b, dtype=np.longdouble)
    for k in range(1, count + 1):
        term = _product(a_fixed, term)
        out[k] = _to_longdouble(*term)
    return out
