"""Persistent excitation: is the input rich enough for a model of the requested order?

An input is persistently exciting of order ``r`` when its block-Hankel matrix of depth ``r``
(rows = sliding windows of ``r`` samples of every input channel) has full rank. A constant
has rank 1, one sinusoid rank 2, a sum of ``k`` sinusoids rank ``2k``; white noise and a
PRBS have full rank at any depth. Identifying an ``n``-th order model needs (Ljung, *System
Identification: Theory for the User*, 2nd ed., 1999, sec. 13.2, informative open-loop
experiments: a rational ``B/F`` model with ``n_b + n_f`` coefficients needs an input
persistently exciting of order ``n_b + n_f``):

* every input ``j``: rank ``>= n + delta`` beyond what the other inputs already span (its
  ``n`` numerator coefficients, plus ``D`` when ``delta = 1``, i.e. with feedthrough); an
  input that repeats another one (``u[1] = 2 u[0]``) adds nothing and fails;
* all inputs together: rank ``>= n + m (n + delta)`` (the ``n`` shared poles and the
  numerators of the ``m`` inputs); ``2 n + delta`` for one input.

The rank is read from the Gram matrix of the data windows that the method accumulates
anyway (:func:`gbpipe.sysid.hankel.hankel_gram`), so the check costs one small symmetric
eigenvalue problem and runs before the heavy steps. A window of depth ``d`` can show at
most rank ``m d``: when the requirement exceeds it, full rank over the window is accepted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gbpipe.errors import ExcitationError
from gbpipe.memo import ArrayMemo, array_key

__all__ = [
    "PE_RTOL",
    "InputRank",
    "input_hankel_rank",
    "required_rank",
    "max_excited_order",
    "check_excitation",
    "excitation_limit",
]

#: Relative tolerance on the eigenvalues of the input Gram matrix (i.e. ``sqrt(1e-9)`` ~
#: 3e-5 on the singular values of the channel-scaled Hankel matrix, -90 dB in power): far
#: above the rounding of the lagged correlations (~1e-13 at N = 1e6), far below any
#: excitation an identification can use.
PE_RTOL = 1e-12


@dataclass(frozen=True)
class InputRank:
    """Numerical rank of the input block-Hankel matrix.

    Attributes
    ----------
    depth : int
        Window length ``d`` in samples (block rows of the Hankel matrix).
    total : int
        Rank of the joint matrix of all ``m`` inputs (at most ``m d``).
    per_input : tuple of int
        Rank of each input's own Hankel matrix (at most ``d``).
    unique : tuple of int
        Rank each input adds to all the others: ``total`` minus the rank without input
        ``j`` (equal to ``total`` for one input).
    """

    depth: int
    total: int
    per_input: tuple[int, ...]
    unique: tuple[int, ...]

    @property
    def n_inputs(self) -> int:
        """Number of input channels ``m``."""
        return len(self.per_input)


# Ranks of the most recent input Gram matrices: the methods, pairings and jackknife fits of
# one record check the same input again and again, and the eigenvalues cost more than the
# comparison of the matrix's bytes.
_RANKS = ArrayMemo(32)


def _rank(g: np.ndarray, rtol: float) -> int:
    """Numerical rank of a symmetric positive semi-definite matrix."""
    w = np.linalg.eigvalsh(0.5 * (g + g.T))
    top = float(w[-1]) if w.size else 0.0
    return int(np.sum(w > rtol * top)) if top > 0.0 else 0


def _input_rank(g: np.ndarray, n_inputs: int, depth: int, rtol: float) -> InputRank:
    """:func:`input_hankel_rank` from the input block ``g`` (indexed ``lag * m + input``)."""
    m = n_inputs
    lags = np.arange(depth)
    ranks: dict[tuple[int, ...], int] = {}  # by the inputs kept: one eigenproblem each

    def rank_of(inputs: tuple[int, ...]) -> int:
        if inputs not in ranks:
            idx = (lags[:, None] * m + np.array(inputs)[None, :]).ravel()
            ranks[inputs] = _rank(g[np.ix_(idx, idx)], rtol) if idx.size else 0
        return ranks[inputs]

    total = rank_of(tuple(range(m)))
    per = tuple(rank_of((j,)) for j in range(m))
    unique = tuple(total - rank_of(tuple(k for k in range(m) if k != j)) for j in range(m))
    return InputRank(depth, total, per, unique)


def input_hankel_rank(
    gram: np.ndarray, n_inputs: int, depth: int, rtol: float = PE_RTOL
) -> InputRank:
    """Rank of the input block-Hankel matrix from the Gram matrix of the data windows.

    Parameters
    ----------
    gram : ndarray, shape (c * depth, c * depth)
        ``hankel_gram(z, depth)`` of the channel-scaled signals ``z`` (inputs in the first
        ``n_inputs`` of the ``c`` channels), indexed ``lag * c + channel``.
    n_inputs : int
        Number of input channels ``m``.
    depth : int
        Window length ``d`` used for ``gram``.
    rtol : float
        Eigenvalues below ``rtol`` times the largest count as zero.

    Returns
    -------
    InputRank
    """
    c = gram.shape[0] // depth
    idx = (np.arange(depth)[:, None] * c + np.arange(n_inputs)[None, :]).ravel()
    g = gram[np.ix_(idx, idx)]  # every rank below is of a sub-block of it
    return _RANKS((n_inputs, depth, rtol, array_key(g)),
                  lambda: _input_rank(g, n_inputs, depth, rtol))


def required_rank(order: int, n_inputs: int, depth: int, feedthrough: bool) -> tuple[int, int]:
    """Input Hankel rank an order-``n`` model needs (module docstring).

    Returns
    -------
    joint, per_input : int
        Rank needed of the joint and of each input's matrix, capped at what a window of
        ``depth`` samples can show (``m d`` and ``d``).
    """
    delta = int(feedthrough)
    per = order + delta
    joint = order + n_inputs * per
    return min(n_inputs * depth, joint), min(depth, per)


def max_excited_order(rank: InputRank, feedthrough: bool) -> int | None:
    """Largest order the input supports; None when the input has full rank over the window.

    Returns
    -------
    int or None
        ``0`` when not even a first-order model is supported.
    """
    m, d, delta = rank.n_inputs, rank.depth, int(feedthrough)
    bounds = []
    if rank.total < m * d:
        bounds.append((rank.total - m * delta) // (m + 1))
    if min(rank.unique) < d:
        bounds.append(min(rank.unique) - delta)
    return max(0, min(bounds)) if bounds else None


def _describe(j: int, r: int, depth: int) -> str:
    """One input's excitation in words, from the rank of its Hankel matrix."""
    if r <= 1:
        return f"input {j} ('u[{j}]') is constant"
    k = r // 2
    return (f"input {j} ('u[{j}]') has rank {r} over the {depth}-sample window, i.e. at most "
            f"{k} sinusoid{'s' if k != 1 else ''}{' plus a constant' if r % 2 else ''}")


def check_excitation(
    rank: InputRank, order: int, feedthrough: bool, window_desc: str
) -> None:
    """Refuse an input that is not persistently exciting enough for ``order``.

    Parameters
    ----------
    rank : InputRank
        From :func:`input_hankel_rank`.
    order : int
        Model order ``n`` requested.
    feedthrough : bool
        Whether ``D`` is estimated.
    window_desc : str
        How the window depth arises from the method's arguments, e.g. ``"past 20 + 1"``.

    Raises
    ------
    ExcitationError
        Joint rank, or the rank an input adds to the others, below :func:`required_rank`;
        the message gives the ranks against the order's needs, what excitation is missing,
        and the largest order this input supports.
    """
    joint, per = required_rank(order, rank.n_inputs, rank.depth, feedthrough)
    if rank.total >= joint and min(rank.unique) >= per:
        return
    m, d, delta = rank.n_inputs, rank.depth, int(feedthrough)
    poor = [j for j, r in enumerate(rank.per_input) if r < per]
    if poor or m == 1:
        j = poor[0] if poor else 0
        what = _describe(j, rank.per_input[j], d)
        need = per if poor else joint
        missing = f"excitation at {-(-need // 2)} or more distinct frequencies"
    elif min(rank.unique) < per:
        j = int(np.argmin(rank.unique))
        what = (f"input {j} ('u[{j}]') adds only rank {rank.unique[j]} to the other "
                f"input{'s' if m > 2 else ''} (ranks {list(rank.per_input)} each, "
                f"{rank.total} together): the inputs are nearly linearly dependent")
        missing = f"excitation of input {j} independent of the others"
    else:
        what = f"the {m} inputs together carry rank {rank.total} only"
        missing = f"excitation at {-(-(joint - rank.total) // 2)} or more further frequencies"
    n_ok = max_excited_order(rank, feedthrough)
    fix = (f"lower the order to <= {n_ok}, or " if n_ok else "") + (
        "excite with broadband noise, a PRBS or a multisine")
    raise ExcitationError(
        f"{what}. The input block-Hankel matrix of depth {d} ({window_desc}) has rank "
        f"{rank.total} (of {m * d}); model order {order} needs rank >= {joint} "
        f"(n + m (n + {delta}) with m = {m}, capped at {m * d}) and >= {per} from each input "
        f"beyond the others. Missing: {missing}; {fix}"
    )


def excitation_limit(
    gram: np.ndarray,
    n_inputs: int,
    depth: int,
    order: int | None,
    feedthrough: bool,
    window_desc: str,
) -> tuple[InputRank, int | None]:
    """Input rank, checked against a fixed order, and the order cap for ``"auto"``.

    Parameters
    ----------
    gram : ndarray
        ``hankel_gram(z, depth)`` of the channel-scaled record (inputs first).
    n_inputs, depth : int
    order : int or None
        Fixed model order, or None for ``"auto"`` (then only order 1 must be supported).
    feedthrough : bool
    window_desc : str
        See :func:`check_excitation`.

    Returns
    -------
    rank : InputRank
    cap : int or None
        Largest order the input supports (None: full rank over the window, no cap).

    Raises
    ------
    ExcitationError
        See :func:`check_excitation`.
    """
    rank = input_hankel_rank(gram, n_inputs, depth)
    check_excitation(rank, 1 if order is None else order, feedthrough, window_desc)
    return rank, max_excited_order(rank, feedthrough)
