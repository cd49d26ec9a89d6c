"""Result type of the subspace methods: a discrete-time innovation-form state-space model.

``x[k+1] = A x[k] + B u[k] + K e[k]``, ``y[k] = C x[k] + D u[k] + e[k]``, ``cov(e) = noise_cov``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._common import as_2d, check_finite

__all__ = ["SubspaceModel", "simulate_ss"]

# Samples per block of the lifted simulation (see simulate_ss).
_BLOCK = 64


def _lifted(a, b, c, d, k):
    """Matrices of the k-step lifted system: observability, Toeplitz, controllability, A^k."""
    n, m = b.shape
    l_ = c.shape[0]
    obs = np.empty((k * l_, n))
    ctrb = np.empty((n, k * m))
    markov = np.empty((k, l_, m))  # markov[i] = C A^(i-1) B, markov[0] = D
    markov[0] = d
    ai = np.eye(n)
    for i in range(k):
        obs[i * l_: (i + 1) * l_] = c @ ai
        ctrb[:, (k - 1 - i) * m: (k - i) * m] = ai @ b
        if i + 1 < k:
            markov[i + 1] = c @ ai @ b
        ai = a @ ai
    # Block (i, j) of the lower block-triangular Toeplitz matrix is markov[i - j] for i >= j.
    lag = np.subtract.outer(np.arange(k), np.arange(k))
    blocks = markov[np.maximum(lag, 0)] * (lag >= 0)[:, :, None, None]  # (k, k, l, m)
    toe = blocks.transpose(0, 2, 1, 3).reshape(k * l_, k * m)
    return obs, toe, ctrb, ai


def simulate_ss(
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    d: np.ndarray,
    u: np.ndarray,
    x0: np.ndarray | None = None,
) -> np.ndarray:
    """Simulate ``x+ = A x + B u``, ``y = C x + D u`` for ``u`` of shape (N, m).

    The record is cut into blocks of 64 samples; inside a block the response is one matrix
    product with the lifted (block-Toeplitz) system, so the Python-level loop runs only
    ``N / 64`` times over an ``n``-vector recursion. Unlike a modal (diagonalised) filter this
    stays accurate for defective or badly conditioned ``A``.

    Parameters
    ----------
    a, b, c, d : ndarray
        State-space matrices, shapes (n, n), (n, m), (l, n), (l, m).
    u : ndarray, shape (N, m)
        Input samples (units of the model's input).
    x0 : ndarray, shape (n,) or (n, r), optional
        Initial state(s); zeros when omitted. With ``r`` columns and ``m == 0`` inputs the
        free responses of ``r`` initial states are returned side by side.

    Returns
    -------
    ndarray, shape (N, l) or (N, l, r)
        Output samples.
    """
    n_s, m = u.shape
    n = a.shape[0]
    l_ = c.shape[0]
    k = max(1, min(_BLOCK, n_s))
    nb = -(-n_s // k)
    up = np.zeros((nb * k, m))
    up[:n_s] = u
    ub = up.reshape(nb, k * m)
    obs, toe, ctrb, ak = _lifted(a, b, c, d, k)
    x0a = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float)
    multi = x0a.ndim == 2
    xs = x0a if multi else x0a[:, None]
    drive = ub @ ctrb.T  # (nb, n): state increment of each block from its inputs
    states = np.empty((nb, n, xs.shape[1]))
    x = xs.copy()
    for i in range(nb):
        states[i] = x
        x = ak @ x + drive[i][:, None]
    yb = np.einsum("ij,bjr->bir", obs, states) + (ub @ toe.T)[:, :, None]
    y = yb.reshape(nb, k, l_, xs.shape[1]).reshape(nb * k, l_, xs.shape[1])[:n_s]
    return y if multi else y[:, :, 0]


def _freeze(x: np.ndarray) -> np.ndarray:
    arr = np.array(x, dtype=float, copy=True)
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True)
class SubspaceModel:
    """Identified discrete-time model in innovation form.

    ``x[k+1] = A x[k] + B u[k] + K e[k]``, ``y[k] = C x[k] + D u[k] + e[k]``.
    Units are those of the data passed to the identification: B maps input units to state,
    C maps state to output units, ``noise_cov`` is in output units squared.

    Attributes
    ----------
    A, B, C, D, K : ndarray
        System matrices, shapes (n, n), (n, m), (l, n), (l, m), (n, l).
    noise_cov : ndarray, shape (l, l)
        Covariance of the innovation ``e``.
    singular_values : ndarray
        Singular values used for the order decision (of the channel-scaled data, normalised
        per window, so they are comparable between records of different length).
    dt : float
        Sample time in seconds.
    method : str
        ``"pbsid"``, ``"moesp"`` or ``"n4sid"``.
    order : int
        State dimension ``n``.
    past, future : int
        Window lengths used, in samples.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    K: np.ndarray
    noise_cov: np.ndarray
    singular_values: np.ndarray
    dt: float
    method: str
    order: int
    past: int = 0
    future: int = 0
    info: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("A", "B", "C", "D", "K", "noise_cov", "singular_values"):
            object.__setattr__(self, name, _freeze(getattr(self, name)))

    @property
    def n_inputs(self) -> int:
        """Number of input channels ``m``."""
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        """Number of output channels ``l``."""
        return self.C.shape[0]

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (discrete-time, dimensionless)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every eigenvalue of ``A`` lies strictly inside the unit circle."""
        return bool(np.all(np.abs(self.poles) < 1.0))

    def to_statespace(self):
        """Deterministic part as ``control.StateSpace(A, B, C, D, dt)``."""
        import control

        return control.ss(self.A, self.B, self.C, self.D, self.dt)

    def frf(self, freq_hz: object) -> np.ndarray:
        """Frequency response ``C (z I - A)^-1 B + D`` at ``z = exp(2j pi f dt)``.

        Parameters
        ----------
        freq_hz : array_like
            Frequencies in Hz (any shape is flattened).

        Returns
        -------
        ndarray, complex, shape (n_freq, l, m)
        """
        f = np.atleast_1d(np.asarray(freq_hz, dtype=float)).ravel()
        check_finite(f[:, None], "freq_hz")
        z = np.exp(2j * np.pi * f * self.dt)
        n = self.order
        mat = z[:, None, None] * np.eye(n) - self.A
        g = np.linalg.solve(mat, np.broadcast_to(self.B, (f.size, n, self.n_inputs)))
        return self.C @ g + self.D

    def _check_u(self, u: object, name: str = "u") -> np.ndarray:
        ua = as_2d(u, name)
        if ua.shape[1] != self.n_inputs:
            raise ValueError(
                f"{name} has {ua.shape[1]} channels but the model has {self.n_inputs} inputs"
            )
        check_finite(ua, name)
        return ua

    def simulate(self, u: object, x0: object = None) -> np.ndarray:
        """Noise-free output for input ``u`` (shape (N,) or (N, m)) from state ``x0``.

        Parameters
        ----------
        u : array_like
            Input samples in the model's input units.
        x0 : array_like, shape (n,), optional
            Initial state; zero by default.

        Returns
        -------
        ndarray, shape (N, l)
        """
        ua = self._check_u(u)
        if x0 is not None:
            x0 = np.asarray(x0, dtype=float).reshape(self.order)
        return simulate_ss(self.A, self.B, self.C, self.D, ua, x0)

    def estimate_x0(self, u: object, y: object) -> np.ndarray:
        """Least-squares initial state for the simulation of ``u`` against ``y``.

        Parameters
        ----------
        u, y : array_like
            Input and output records (same length; shapes (N,) or (N, channels)).

        Returns
        -------
        ndarray, shape (n,)
        """
        ua = self._check_u(u)
        ya = as_2d(y, "y")
        check_finite(ya, "y")
        if ya.shape != (ua.shape[0], self.n_outputs):
            raise ValueError(
                f"y must have shape ({ua.shape[0]}, {self.n_outputs}) to match u and the "
                f"model, got {ya.shape}"
            )
        resid = ya - simulate_ss(self.A, self.B, self.C, self.D, ua)
        free = simulate_ss(
            self.A, np.zeros((self.order, 0)), self.C, np.zeros((self.n_outputs, 0)),
            np.zeros((ua.shape[0], 0)), np.eye(self.order),
        )  # (N, l, n): output of each unit initial state
        ok = np.all(np.isfinite(free), axis=(1, 2))
        # An unstable model's free response overflows; fit x0 on the finite head only.
        stop = ua.shape[0] if ok.all() else int(np.argmin(ok))
        phi = free[:stop].reshape(-1, self.order)
        x0, *_ = np.linalg.lstsq(phi, resid[:stop].ravel(), rcond=None)
        return x0

    def fit(self, u: object, y: object, x0: object = "estimate") -> np.ndarray:
        """Simulation fit in percent per output: ``100 (1 - ||y - y_sim|| / ||y - mean(y)||)``.

        Parameters
        ----------
        u, y : array_like
            Validation input and output records.
        x0 : "estimate", None or array_like
            Initial state: least-squares estimate (default), zero (None), or given.

        Returns
        -------
        ndarray, shape (l,)
        """
        ya = as_2d(y, "y")
        if isinstance(x0, str) and x0 == "estimate":
            x0 = self.estimate_x0(u, ya)
        ysim = self.simulate(u, x0)
        num = np.linalg.norm(ya - ysim, axis=0)
        den = np.linalg.norm(ya - ya.mean(axis=0), axis=0)
        return 100.0 * (1.0 - num / den)


def from_scaled(
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    d: np.ndarray,
    k: np.ndarray,
    noise_cov: np.ndarray,
    u_scale: np.ndarray,
    y_scale: np.ndarray,
    **meta,
) -> SubspaceModel:
    """Undo the channel scaling ``u_s = u / u_scale``, ``y_s = y / y_scale`` of a model."""
    return SubspaceModel(
        A=a,
        B=b / u_scale[None, :],
        C=y_scale[:, None] * c,
        D=y_scale[:, None] * d / u_scale[None, :],
        K=k / y_scale[None, :],
        noise_cov=y_scale[:, None] * noise_cov * y_scale[None, :],
        **meta,
    )
