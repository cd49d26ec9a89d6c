"""Result type of the subspace methods: a discrete-time innovation-form state-space model.

``x[k+1] = A x[k] + B u[k] + K e[k]``, ``y[k] = C x[k] + D u[k] + e[k]``, ``cov(e) = noise_cov``.
Its deterministic part ``(A, B, C, D, dt)`` is a :class:`gbpipe.lti.NamedSS` (:attr:`ss`);
simulation, frequency response and fit are those of the one LTI core, :mod:`gbpipe.lti`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gbpipe.errors import DataError
from gbpipe.lti import NamedSS, dlsim, fit_percent, frf
from gbpipe.memo import ArrayMemo, array_key
from gbpipe.sysid.checks import as_2d, check_finite

__all__ = ["SubspaceModel", "from_scaled", "free_response"]

# Segment lengths whose x0 solver a model keeps (a validation uses one or two).
_X0_CACHE = 4


def free_response(a: np.ndarray, c: np.ndarray, n_samples: int) -> np.ndarray:
    """Output of every unit initial state: ``out[k, :, i] = (C A^k)[:, i]``.

    Each output row ``r`` is the impulse response of the transposed system
    ``s+ = A' s + C[r]' v`` read from its state (``s[k + 1] = (A')^k C[r]'``), so one exact
    simulation per output gives all ``n`` free responses.

    Parameters
    ----------
    a : ndarray, shape (n, n)
    c : ndarray, shape (l, n)
    n_samples : int

    Returns
    -------
    ndarray, shape (n_samples, l, n)
    """
    n = a.shape[0]
    out = np.empty((n_samples, c.shape[0], n))
    pulse = np.zeros((n_samples + 1, 1))
    pulse[0] = 1.0
    for r in range(c.shape[0]):
        out[:, r, :] = dlsim(a.T, c[r][:, None], np.eye(n), np.zeros((n, 1)), pulse)[1:]
    return out


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
    info : dict
        Method details (number of windows, feedthrough, input Hankel rank, ...).
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
        # Least-squares x0 solvers by segment length (a validation calls estimate_x0 on many
        # segments of one length); not a field, so replace() starts a fresh cache.
        object.__setattr__(self, "_x0_solvers", {})
        # The last frequency grid and its response: the identify stage evaluates a model
        # with confidence bounds on the same grid twice (gbpipe.sysid.frf_bounds, then the
        # score against the reference).
        object.__setattr__(self, "_frfs", ArrayMemo(1))

    def x0_solver(self, n_samples: int) -> tuple[int, np.ndarray, np.ndarray]:
        """Free response over ``n_samples`` and its pseudo-inverse, cached by length.

        Returns
        -------
        stop : int
            Samples used: all, or the finite head of an unstable model's free response.
        pinv : ndarray, shape (n, stop * l)
            ``x0 = pinv @ (y - y_forced)[:stop].ravel()`` is the least-squares initial state.
        free : ndarray, shape (n_samples, l, n)
            :func:`free_response` of the model.
        """
        cache = self._x0_solvers
        if n_samples not in cache:
            free = free_response(self.A, self.C, n_samples)
            ok = np.all(np.isfinite(free), axis=(1, 2))
            # An unstable model's free response overflows; fit x0 on the finite head only.
            stop = n_samples if ok.all() else int(np.argmin(ok))
            if len(cache) >= _X0_CACHE:
                cache.pop(next(iter(cache)))
            phi = free[:stop].reshape(-1, self.order)
            # The singular-value cut of np.linalg.lstsq(rcond=None), so both agree.
            cut = np.finfo(float).eps * max(phi.shape)
            cache[n_samples] = (stop, np.linalg.pinv(phi, rcond=cut), free)
        return cache[n_samples]

    @property
    def n_inputs(self) -> int:
        """Number of input channels ``m``."""
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        """Number of output channels ``l``."""
        return self.C.shape[0]

    @property
    def ss(self) -> NamedSS:
        """Deterministic part ``(A, B, C, D)`` as a discrete :class:`gbpipe.lti.NamedSS`.

        Signals are named ``u[j]``, ``y[i]`` and states ``x[k]`` (sysid sees no names).
        For a ``control.StateSpace``: ``gbpipe.lti.control_io.to_control(model.ss)``.
        """
        return NamedSS(
            A=self.A, B=self.B, C=self.C, D=self.D,
            states=[f"x[{k}]" for k in range(self.order)],
            inputs=[f"u[{j}]" for j in range(self.n_inputs)],
            outputs=[f"y[{i}]" for i in range(self.n_outputs)],
            dt=self.dt,
        )

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (discrete-time, dimensionless)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every eigenvalue of ``A`` lies strictly inside the unit circle."""
        return bool(np.all(np.abs(self.poles) < 1.0))

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
        # a copy: the memo's value is read-only, and the caller may write into its result
        return self._frfs(array_key(f), lambda: frf(self.ss, f)).copy()

    def _check_u(self, u: object, name: str = "u") -> np.ndarray:
        ua = as_2d(u, name)
        if ua.shape[1] != self.n_inputs:
            raise DataError(
                name, f"{name} has {ua.shape[1]} channels but the model has {self.n_inputs} "
                "inputs"
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
        return dlsim(self.A, self.B, self.C, self.D, ua, x0)

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
            raise DataError(
                "y", f"y must have shape ({ua.shape[0]}, {self.n_outputs}) to match u and "
                f"the model, got {ya.shape}"
            )
        resid = ya - dlsim(self.A, self.B, self.C, self.D, ua)
        stop, pinv, _ = self.x0_solver(ua.shape[0])
        return pinv @ resid[:stop].ravel()

    def simulate_segments(self, u: object, y: object, segment: int
                          ) -> tuple[np.ndarray, np.ndarray]:
        """Simulation of ``u`` in segments, each from its least-squares initial state.

        Equivalent to :meth:`estimate_x0` and :meth:`simulate` on every segment
        ``[k segment, (k + 1) segment)`` (the last one shorter), but for a stable model the
        record is simulated once and all full segments share one batched solve: segment
        ``k``'s response from its own ``x0`` is the one-pass response plus the free response
        of ``x0 - x[k segment]``.

        Parameters
        ----------
        u, y : array_like
            Input and output records, shapes (N,) or (N, channels).
        segment : int
            Segment length in samples (``>= order`` for a determined initial state).

        Returns
        -------
        y_sim : ndarray, shape (N, l)
        x0 : ndarray, shape (n_segments, n)
            Initial state of each segment.
        """
        ua = self._check_u(u)
        ya = as_2d(y, "y")
        n_tot, n = ua.shape[0], self.order
        starts = np.arange(0, n_tot, segment)
        if not self.is_stable():  # one long simulation would overflow: segment by segment
            x0 = np.array([self.estimate_x0(ua[a: a + segment], ya[a: a + segment])
                           for a in starts])
            y_sim = np.vstack([self.simulate(ua[a: a + segment], x)
                               for a, x in zip(starts, x0, strict=True)])
            return y_sim, x0
        states = dlsim(self.A, self.B, np.eye(n), np.zeros((n, self.n_inputs)), ua)
        y_one = states @ self.C.T + ua @ self.D.T
        dev = ya - y_one
        y_sim = y_one.copy()
        x0 = states[starts].copy()
        for length, group in ((segment, starts[starts + segment <= n_tot]),
                              (n_tot - starts[-1], starts[starts + segment > n_tot])):
            if group.size == 0:
                continue
            stop, pinv, free = self.x0_solver(length)
            rows = group[:, None] + np.arange(length)[None, :]  # (segments, length)
            dx = dev[rows[:, :stop]].reshape(group.size, -1) @ pinv.T  # (segments, n)
            y_sim[rows] += np.einsum("tln,sn->stl", free, dx)
            x0[np.searchsorted(starts, group)] += dx
        return y_sim, x0

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
        return fit_percent(ya, self.simulate(u, x0))


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
