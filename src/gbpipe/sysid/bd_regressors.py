"""Regressors of the ``B, D`` least squares, simulated piece by piece over a record.

With ``A, C`` fixed, ``y[t] = C A^t x0 + sum_k C A^(t-1-k) B u[k] + D u[t]`` is linear in
``(B, D, x0)``; the regressor of ``B[:, j]`` on output ``r`` is the state of the transposed
system ``s+ = A' s + C[r]' u_j`` and that of ``x0`` the free response ``(C A^t)[r]``.
:class:`BDRegressors` simulates them in pieces (sample by sample while the free response
lasts, then as block products); :func:`gbpipe.sysid.input_matrices.bd_least_squares` turns
them into the Gram matrix of the regression.
"""

from __future__ import annotations

import numpy as np

from gbpipe.lti import dlsim

__all__ = ["BDRegressors"]

# A free response below this fraction of its start (|C A^t| against |C|) contributes
# nothing to the normal equations at float64 precision; later chunks leave it at zero.
_FREE_DECAYED = 1e-20


class BDRegressors:
    """The regressors of :func:`bd_least_squares`, simulated piece by piece over the record.

    The simulations carry their states from piece to piece, so consecutive pieces join
    seamlessly: ``s_(r,j)``, the state of ``s+ = A' s + C[r]' u_j`` (the regressors of
    ``B[:, j]`` on output ``r``), and the free response ``(C A^t)[r]`` (those of ``x0``).
    A piece is either simulated sample by sample (:meth:`explicit`) or, once the free
    response has decayed, reduced to block products (:meth:`add_blocks`, :meth:`block_gram`).

    Parameters
    ----------
    a, c : ndarray
        ``A`` (n, n) and ``C`` (l, n).
    z : ndarray, shape (m + l, N)
        Inputs (first ``m`` rows) and outputs.
    n_inputs : int
        ``m``.
    length : int
        Block length ``L`` of the block products, in samples.
    """

    def __init__(self, a: np.ndarray, c: np.ndarray, z: np.ndarray, n_inputs: int,
                 length: int) -> None:
        n, l_ = a.shape[0], c.shape[0]
        self.n, self.m, self.c, self.z, self.length = n, n_inputs, c, z, length
        self.at = np.ascontiguousarray(a.T)
        self.s_b = np.zeros((l_, n_inputs, n))
        self.s_f = c.astype(float, copy=True)
        self.free_floor = _FREE_DECAYED * max(float(np.max(np.abs(c))), np.finfo(float).tiny)
        # Powers of A' in extended precision, rounded once (as in gbpipe.lti.dlsim): the
        # lifted recursion s_(b+1) = (A')^L s_b + R u_b runs over N / L blocks.
        pw = np.empty((length + 1, n, n), dtype=np.longdouble)
        pw[0] = np.eye(n)
        for q in range(1, length + 1):
            pw[q] = self.at.astype(np.longdouble) @ pw[q - 1]
        self.powers = pw
        self.markov = pw[:length] @ c.T.astype(np.longdouble)  # [q] = (A')^q C', (L, n, l)
        self.n_states = l_ * n_inputs * n
        # v_b = [B states (l m n); free-response states (l n); u and y block samples].
        self.n_lead = self.n_states + l_ * n
        self.gram_v = np.zeros((self.n_lead + (n_inputs + l_) * length,) * 2)

    @property
    def free(self) -> bool:
        """Whether the free response is still above float64 resolution (else zero)."""
        return bool(np.max(np.abs(self.s_f)) > self.free_floor)

    def explicit(self, t0: int, t1: int) -> tuple[np.ndarray, list[np.ndarray], bool]:
        """Regressors of samples ``t0 .. t1 - 1``, sample by sample.

        Returns
        -------
        zc : ndarray, shape (m + l, T)
            The record over the piece (a view).
        xs : list of ndarray, one per output ``r``, shape (T, n + n m) or (T, n m)
            ``[(C A^t)[r], s_(r,0), ..., s_(r,m-1)]``; the free response is left out
            when ``free`` is False.
        free : bool
        """
        n = self.n
        eye, zero_n1 = np.eye(n), np.zeros((n, 1))
        zc = self.z[:, t0:t1]
        free = self.free
        xs = []
        for r_ in range(self.c.shape[0]):
            parts = []
            if free:
                # (C A^t)[r] is the unforced state of the transposed system from C[r]'.
                resp, self.s_f[r_] = dlsim(self.at, zero_n1, eye, zero_n1,
                                           np.zeros((t1 - t0, 1)), x0=self.s_f[r_],
                                           return_state=True)
                parts.append(resp)
            for j in range(self.m):
                states, self.s_b[r_, j] = dlsim(
                    self.at, self.c[r_][:, None], eye, zero_n1, zc[j][:, None],
                    x0=self.s_b[r_, j], return_state=True,
                )
                parts.append(states)
            xs.append(parts[0] if len(parts) == 1 else np.hstack(parts))
        return zc, xs, free

    def add_blocks(self, t0: int, n_blocks: int) -> None:
        """Accumulate ``V = sum_b v_b v_b'`` over ``n_blocks`` blocks from sample ``t0``.

        ``v_b = [s_b (all r, j); free states (all r); u block; y block]``: the states at the
        block start and the block's samples. Only the block starts are simulated (the
        lifted system), not the states at every sample; the free response ``(C A^t)[r]``
        is the unforced state of the same transposed system, so it is lifted the same way
        (left at zero once it has decayed below float64 resolution).
        """
        n, m, L, ns = self.n, self.m, self.length, self.n_states
        l_ = self.c.shape[0]
        free = self.free
        seg = self.z[:, t0: t0 + n_blocks * L].reshape(m + l_, n_blocks, L)
        v = np.empty((n_blocks, self.gram_v.shape[0]))
        for r_ in range(l_):
            lifted_b = self.markov[::-1, :, r_].T  # column i: (A')^(L-1-i) C[r]'
            for j in range(m):
                col = (r_ * m + j) * n
                v[:, col: col + n], self.s_b[r_, j] = dlsim(
                    self.powers[L], lifted_b, np.eye(n), np.zeros((n, L)), seg[j],
                    x0=self.s_b[r_, j], return_state=True,
                )
            col = ns + r_ * n
            if free:
                v[:, col: col + n], self.s_f[r_] = dlsim(
                    self.powers[L], np.zeros((n, 1)), np.eye(n), np.zeros((n, 1)),
                    np.zeros((n_blocks, 1)), x0=self.s_f[r_], return_state=True,
                )
            else:
                v[:, col: col + n] = 0.0
        v[:, self.n_lead:] = seg.transpose(1, 0, 2).reshape(n_blocks, (m + l_) * L)
        self.gram_v += v.T @ v

    def block_gram(self, feedthrough: bool) -> np.ndarray:
        """Gram matrix of ``[Phi y]`` over the blocks of :meth:`add_blocks`.

        Within a block starting at ``t_b``, the regressor at ``t_b + k`` is
        ``(A')^k s_b`` plus a Toeplitz product with the block's inputs, so every row of
        ``[Phi y]`` there is ``F_(r,k) v_b``, and the Gram matrix is
        ``sum_(r,k) F_(r,k) V F_(r,k)'``.

        Returns
        -------
        ndarray, shape (k + 1, k + 1)
            Symmetric; columns ``[x0, B, D, y]`` as in :func:`bd_least_squares`.
        """
        n, m, L, ns, lead = self.n, self.m, self.length, self.n_states, self.n_lead
        l_ = self.c.shape[0]
        nb = n + n * m
        k = nb + (l_ * m if feedthrough else 0)
        toep = np.zeros((L, n, L, l_))  # toep[q, :, i, r] = (A')^(q-1-i) C[r]', i < q
        for q in range(1, L):
            toep[q, :, :q, :] = self.markov[q - 1:: -1].transpose(1, 0, 2).astype(float)
        f_all = np.zeros((l_, L, k + 1, self.gram_v.shape[0]))
        samples = np.arange(L)
        for r_ in range(l_):
            f_all[r_, :, :n, ns + r_ * n: ns + (r_ + 1) * n] = self.powers[:L].astype(float)
            for j in range(m):
                rows = slice(n + j * n, n + (j + 1) * n)
                col, u0 = (r_ * m + j) * n, lead + j * L
                f_all[r_, :, rows, col: col + n] = self.powers[:L].astype(float)
                f_all[r_, :, rows, u0: u0 + L] = toep[:, :, :, r_]
                if feedthrough:
                    f_all[r_, samples, nb + r_ * m + j, u0 + samples] = 1.0
            f_all[r_, samples, k, lead + (m + r_) * L + samples] = 1.0
        f_all = f_all.reshape(l_ * L, k + 1, -1)
        fv = (f_all @ self.gram_v).transpose(1, 0, 2).reshape(k + 1, -1)
        return fv @ f_all.transpose(1, 0, 2).reshape(k + 1, -1).T
