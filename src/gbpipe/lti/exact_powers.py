"""Matrix powers and Krylov products correct to the last bit of ``np.longdouble``, by
exact integer arithmetic in float64 limbs.

The chain ``A^(k+1) = A A^k`` in floating point loses digits where its products cancel:
an entry of ``A A^k`` far smaller than the same entry of ``|A| |A^k|`` (the transient
growth of a strongly non-normal ``A``, e.g. eigenvector condition 1e6 with ``||A||`` of
1e4 and ``||A^k||`` of 1e5) keeps only the digits the cancellation left. Here every
matrix is an integer matrix times a power of two (fixed point, ``_BITS`` bits below the
largest entry), and each product is exact, then truncated once to ``_BITS`` bits. The
truncation, 2^-160 of the largest entry, stays far below the 2^-64 rounding of
``np.longdouble`` even after a cancellation by 2^90, so the results are the exact ones,
rounded once (to within one unit of the last place of ``np.longdouble``).

The integers are held as ``_LIMBS`` limbs of ``_W`` bits (an integer array of shape
``(_LIMBS, ...)``, value ``sum_c limb_c 2^(_W c)``, every limb carrying the entry's sign).
A product of two limb matrices is one float64 matrix product of all limb pairs: each
partial sum is an integer below ``k 2^(2 _W)`` < 2^53 for inner sizes ``k`` < 8192, so
BLAS computes it exactly in any order. The limb sums and carries run in int64.

Used by :mod:`gbpipe.lti.simulation` for the systems whose powers cancel.
"""

from __future__ import annotations

import numpy as np

__all__ = ["exact_krylov", "exact_power"]

# Bits kept below the largest entry of each power (see the module docstring).
_BITS = 160
# Bits per limb: a limb product is below 2^40, a float64 sum of k of them exact for
# k < 2^13 (the inner size of a product: the state count).
_W = 20
_LIMBS = -(-_BITS // _W)
_MAX_INNER = 1 << (53 - 2 * _W)
# Significand bits of a long double (x87 extended: 64; where long double is the float64
# itself, 53).
_MANT = int(np.finfo(np.longdouble).nmant) + 1

# A fixed-point matrix: (limbs, s) with value sum_c limbs[c] 2^(_W c) 2^-s.
_Fixed = tuple[np.ndarray, int]


def _to_fixed(a: np.ndarray) -> _Fixed:
    """``a`` as limbs scaled so that its largest entry is below 2^_BITS; entries below
    2^-_BITS of the largest are truncated (far below any rounding)."""
    a = np.asarray(a, dtype=np.longdouble)
    _, expo = np.frexp(a)
    s = _BITS - (int(expo.max()) if np.any(a) else 0)
    # |a| 2^s < 2^_BITS: each limb is floor(|a| 2^(s - _W c)) mod 2^_W, exact in long
    # double (a power-of-two scaling of a 64-bit significand, and its floor)
    mag = np.ldexp(np.abs(a), s)
    limbs = np.empty((_LIMBS, *a.shape), dtype=np.int64)
    for c in range(_LIMBS):
        t = np.floor(np.ldexp(mag, -_W * c))
        limbs[c] = (t - np.ldexp(np.floor(np.ldexp(t, -_W)), _W)).astype(np.int64)
    return limbs * np.where(a < 0, -1, 1).astype(np.int64), s


def _carry(v: np.ndarray) -> np.ndarray:
    """Limbs of the same integers, every limb but the top in [0, 2^_W) (floor carries,
    from the lowest limb up)."""
    v = v.copy()
    for c in range(len(v) - 1):
        v[c + 1] += v[c] >> _W
        v[c] &= (1 << _W) - 1
    return v


def _magnitude(raw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sign (+1/-1) and limbs in [0, 2^_W) of the integers ``sum_c raw[c] 2^(_W c)``
    (limbs of any size and sign, with room for the carries in the top limbs)."""
    v = _carry(raw)
    sign = np.where(v[-1] < 0, -1, 1).astype(np.int64)  # the top limb holds the sign
    return sign, _carry(v * sign)


def _product(x: _Fixed, y: tuple[np.ndarray, int | np.ndarray], terms: int = 1
             ) -> tuple[np.ndarray, int | np.ndarray]:
    """Exact product of two fixed-point matrices, truncated toward zero to _BITS bits.

    ``y``'s columns may be ``terms`` side-by-side matrices of equal width, each with its
    own scale (``y[1]`` of shape ``(terms,)``): the product is exact column by column, and
    each term's block is truncated relative to its own largest entry (a term far smaller
    than its neighbours keeps its digits). One scale (int) when ``terms`` is 1.
    """
    (xl, xs), (yl, ys) = x, y
    k, n, m = xl.shape[-1], xl.shape[1], yl.shape[-1]
    if k >= _MAX_INNER:
        raise ValueError(f"inner size {k} too large for exact limb products "
                         f"(at most {_MAX_INNER - 1})")
    # every limb pair in one float64 product, exact (module docstring)
    pairs = (xl.reshape(_LIMBS * n, k).astype(float)
             @ yl.transpose(1, 0, 2).reshape(k, _LIMBS * m).astype(float))
    pairs = pairs.astype(np.int64).reshape(_LIMBS, n, _LIMBS, m)
    raw = np.zeros((2 * _LIMBS + 2, n, m), dtype=np.int64)  # two limbs for the carries
    for a in range(_LIMBS):
        raw[a:a + _LIMBS] += pairs[a].transpose(1, 0, 2)
    sign, mag = _magnitude(raw)
    mag = mag.reshape(len(mag), n, terms, m // terms)
    # bits of each term's largest entry: its top limb's position plus that limb's length
    nonzero = mag != 0
    top = len(mag) - 1 - np.argmax(nonzero[::-1], axis=0)
    top_limb = np.take_along_axis(mag, top[None], axis=0)[0]
    bits = np.max(np.where(nonzero.any(axis=0),
                           _W * top + np.frexp(top_limb.astype(float))[1], 0), axis=(0, 2))
    drop = np.maximum(bits - _BITS, 0)                     # (terms,)
    q, r = (v[None, None, :, None] for v in np.divmod(drop, _W))
    # |p| 2^-drop, truncated: whole limbs dropped (q), then r bits shifted across limbs
    mag = np.concatenate([mag, np.zeros((int(q.max()) + 1, *mag.shape[1:]), np.int64)])
    at = np.broadcast_to(q + np.arange(_LIMBS + 1)[:, None, None, None],
                         (_LIMBS + 1, *mag.shape[1:]))
    mag = np.take_along_axis(mag, at, axis=0)
    shifted = (mag[:-1] >> r) | ((mag[1:] & ((1 << r) - 1)) << (_W - r))
    scale = xs + np.asarray(ys) - drop
    return (shifted.reshape(_LIMBS, n, m) * sign,
            int(scale[0]) if terms == 1 and np.ndim(ys) == 0 else scale)


def _to_longdouble(limbs: np.ndarray, s: int | np.ndarray) -> np.ndarray:
    """The fixed-point matrices ``limbs 2^-s`` (every limb carrying its entry's sign, as
    the products leave them) as ``np.longdouble``: the top four limbs of each entry (61 to
    80 bits), rounded once to the long double's significand."""
    sign = np.where((limbs < 0).any(axis=0), -1, 1)
    padded = np.concatenate([np.zeros((3, *limbs.shape[1:]), dtype=np.int64),
                             np.abs(limbs)])
    # each entry's own top limb (index into padded), at least the fourth
    top = np.maximum(len(padded) - 1 - np.argmax((padded != 0)[::-1], axis=0), 3)
    val = np.zeros(limbs.shape[1:], dtype=np.longdouble)
    for j in range(4):  # the first three sums are exact (<= 60 bits); the last rounds
        limb = np.take_along_axis(padded, (top - j)[None], axis=0)[0]
        val = np.ldexp(val, _W) + limb.astype(np.longdouble)
    return sign * np.ldexp(val, _W * (top - 6) - s)


def exact_power(a: np.ndarray, k: int) -> np.ndarray:
    """``a^k`` exact, rounded once to ``np.longdouble`` (binary powering: about
    2 log2(k) exact products).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Square matrix (float64 or longdouble; its value is taken exactly).
    k : int
        Power, >= 1.

    Returns
    -------
    ndarray of np.longdouble, shape (n, n)
        The power, rounded to long double; besides that rounding, at most 2^-160 of
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

    By doubling: with ``[b .. a^(j-1) b]`` known, one product by ``a^j`` (exact, by
    squaring) gives ``[a^j b .. a^(2j-1) b]``: about 2 log2(count) exact products where
    the chain ``a^(k+1) b = a (a^k b)`` takes ``count`` (whose per-product overhead
    dominated the first simulation of a 12-state system: 29 ms of its 80 ms at 2e5
    samples, benchmarks/simulate.py). Each term keeps its own scale and is truncated
    relative to its own largest entry, as in the chain: a term decayed far below the
    others (a stable ``a``, high powers) is as exact as the largest.

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
        The products.
    """
    n, m = np.shape(b)
    power = _to_fixed(a)
    limbs, s = _to_fixed(b)
    blocks = [(limbs[:, None], np.full(1, s))]   # (limbs (L, terms, n, m), scales)
    done = 1
    while done <= count:
        if done > 1:
            power = _product(power, power)        # a^done
        last = np.concatenate([blk[0] for blk in blocks], axis=1)
        # [b ... a^(done-1) b] side by side, each at its own scale: one product by a^done
        side = last.transpose(0, 2, 1, 3).reshape(_LIMBS, n, done * m)
        scales = np.concatenate([blk[1] for blk in blocks])
        prod, ps = _product(power, (side, scales), terms=done)
        blocks.append((prod.reshape(_LIMBS, n, done, m).transpose(0, 2, 1, 3), ps))
        done *= 2
    limbs = np.concatenate([blk[0] for blk in blocks], axis=1)[:, :count + 1]
    scales = np.concatenate([blk[1] for blk in blocks])[:count + 1]
    out = _to_longdouble(limbs, scales[:, None, None])
    out[0] = np.asarray(b, dtype=np.longdouble)  # b itself: exact, not truncated
    return out
