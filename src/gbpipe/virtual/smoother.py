"""Steady-state Kalman filter and Rauch–Tung–Striebel smoother of an estimation model, the
offsets and initial state by generalised least squares, and the 95 % bands.

The gains come from the discrete algebraic Riccati equation
(``scipy.linalg.solve_discrete_are``: the predicted covariance ``P``); the filter and the
smoother are then linear time-invariant recursions, run with the exact block simulator
:func:`gbpipe.lti.dlsim` (forward: the one-step predictor; backward: the RTS recursion
``x̂s[k] = x̂f[k] + G (x̂s[k+1] − x̂p[k+1])``, ``G = P_f Aᵀ P⁻¹``), in blocks of
:data:`BLOCK` samples: the forward pass keeps each block's start state, the backward pass
computes each block's drive again from it but the last's (up to 1.5 times the forward
work, the memory of a block instead of the record's states: hour-long records), and the
estimates leave block by block as it makes them (:meth:`Estimate.blocks`). The
smoothed covariance is the steady state of the RTS covariance recursion, a discrete
Lyapunov equation (``scipy.linalg.solve_discrete_lyapunov``): ``Ps = G Ps Gᵀ + P_f − G P Gᵀ``.

The constant offsets ``b`` and the initial state ``x0`` enter the innovations linearly,
``e[k] = e0[k] − R[k] θ``, ``θ = [x0, b]`` with ``R[k] = [C Φᵏ, Gy + C Σ_{j<k} Φʲ Γ]``
(``Φ`` the predictor's state matrix): they are estimated by generalised least squares over
the whole record (the diffuse prior of a constant; no tuning), the powers ``C Φᵏ`` only
until they have decayed to 1e-10 (past that, a block's innovations enter by their count,
mean and spread: the predictor pass in blocks too). The band of an estimate adds the
offsets' uncertainty (their covariance through the smoother's static gain) to
``C_z Ps C_zᵀ`` and, where an estimate reads a motor torque directly, that torque's noise.
Near the record's ends the band is the steady one (the transient of the initial state is
not in it): the samples where it holds, every estimate's variance within 5 % of its
steady one, are flagged (``Estimate.steady``), the ends' excess variance from the
covariance recursions with the steady gains (``D ← Φ D Φᵀ`` from the initial state's GLS
covariance, ``D ← G D Gᵀ`` from ``P_f − P_s``), evaluated by the stacked free response.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy import linalg

from gbpipe.errors import DataError
from gbpipe.lti import dlsim
from gbpipe.virtual.model import EstimationModel

__all__ = ["BLOCK", "NoiseModel", "Gains", "Estimate", "gains", "innovations", "smooth",
           "Z95"]

#: Two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Size [-] below which the predictor's free response ``C Φᵏ`` counts as decayed.
_DECAYED = 1e-10
#: Relative information [-] below which a direction of the initial state and offsets is
#: left at 0 (pseudo-inverse of the scaled normal matrix).
_RCOND = 1e-8
#: Excess [-] of an estimate's variance over its steady variance at which the start (end)
#: transient ends: the band's half width then within 2.5 % of the true one (a 95 % band
#: holds at least 94.4 %); the samples between are the steady part (``Estimate.steady``).
_TRANSIENT = 0.05
#: Samples [-] per block of the filter and smoother passes (:func:`smooth`): a block's
#: drive and states, (n + r) x 8 B per sample, some 20 MB at 2^16 samples and 30 states;
#: the recursions' own cost per block (lifted matrices, remembered) is paid once.
BLOCK = 1 << 16
#: Points [-] at which a transient's decay is evaluated at most (every sample of a record
#: that short, else every ``ceil(N / _GRID)``-th: a transient ends on that grid).
_GRID = 4096


@dataclass
class NoiseModel:
    """Noise of an estimation model.

    Attributes
    ----------
    sensor_sd : ndarray
        Standard deviation of each measured channel's white noise [its unit].
    input_sd : ndarray
        Standard deviation of each measured motor torque's noise [N·m] (process noise).
    load_rate : ndarray
        Random-walk intensity of each unknown load [N·m/√s] (increment sd per sample:
        ``load_rate·√dt``).
    model_sd : float
        Standard deviation [N·m] of a white torque on every independent coordinate, held
        over a sample: what the model leaves out (it also keeps every state's predicted
        covariance positive).
    """

    sensor_sd: np.ndarray
    input_sd: np.ndarray
    load_rate: np.ndarray
    model_sd: float

    def covariances(self, model: EstimationModel) -> tuple[np.ndarray, np.ndarray]:
        """Process ``Q`` (n, n) and measurement ``R`` (p, p) covariances of ``model``."""
        bu = model.B * self.input_sd
        Q = bu @ bu.T + self.model_sd ** 2 * (model.Bw @ model.Bw.T)
        Q[model.load_states, model.load_states] += self.load_rate ** 2 * model.dt
        return Q, np.diag(self.sensor_sd ** 2)


@dataclass
class Gains:
    """Steady-state filter and smoother of one model and noise.

    Attributes
    ----------
    P, Pf, Ps : ndarray
        Predicted, filtered and smoothed state covariances (n, n).
    K : ndarray
        Filter gain (n, p): ``x̂f = x̂p + K e``.
    S : ndarray
        Innovation covariance (p, p).
    Phi : ndarray
        Predictor state matrix ``A (I − K C)``.
    G : ndarray
        RTS smoother gain (n, n).
    """

    P: np.ndarray
    Pf: np.ndarray
    Ps: np.ndarray
    K: np.ndarray
    S: np.ndarray
    Phi: np.ndarray
    G: np.ndarray


@dataclass
class Estimate:
    """Smoothed estimates of a record.

    Attributes
    ----------
    sd : ndarray
        Standard deviation (r + n_loads,) of each estimate (steady state) [its unit].
    offsets, offsets_sd : ndarray
        Estimated offsets and their standard deviations [N·m].
    neg2_loglik : float
        −2 log-likelihood of the record, the noise scale concentrated out [-].
    scale : float
        That scale: ``Σ eᵀS⁻¹e / (N p)`` [-] (1 for a noise model that fits).
    steady : ndarray of bool (N,)
        Samples where the steady band holds: every estimate's variance within 5 % of its
        steady one. At the start, the initial state's error (its GLS covariance ``Σ₀``)
        through the predictor, ``C_z Φᵏ Σ₀ Φᵏᵀ C_zᵀ`` (the filter's; the smoother's is
        smaller); at the end, the RTS covariance recursion from the filtered covariance,
        exactly ``C_z Gʲ (P_f − P_s) Gʲᵀ C_zᵀ``, ``j`` samples before the last. Both decay
        as ``ρ²ᵏ`` (``ρ`` the spectral radius of ``Φ``, ``G``): a few time constants.
    """

    sd: np.ndarray
    offsets: np.ndarray
    offsets_sd: np.ndarray
    neg2_loglik: float
    scale: float
    steady: np.ndarray
    _passes: Callable[[], Iterator[tuple[int, np.ndarray]]] = field(repr=False)

    def blocks(self) -> Iterator[tuple[int, np.ndarray]]:
        """The estimates block by block, as the smoother's backward pass makes them (the
        last samples first; one block's memory, the filter and smoother run again on each
        call).

        Yields
        ------
        start : int
            The block's first sample [-].
        z : ndarray (n_block, r + n_loads)
            Estimates of samples ``start …`` of ``model.targets`` then the loads [their
            units].
        """
        return self._passes()

    @cached_property
    def z(self) -> np.ndarray:
        """Estimates (N, r + n_loads) of ``model.targets`` then the loads [their units],
        assembled from :meth:`blocks` on first use (N (r + n_loads) 8 bytes: a record that
        fits in memory)."""
        z = np.empty((len(self.steady), len(self.sd)))
        for start, zk in self.blocks():
            z[start:start + len(zk)] = zk
        return z


def gains(model: EstimationModel, noise: NoiseModel) -> Gains:
    """Steady-state Kalman and RTS gains (module docstring).

    Raises
    ------
    gbpipe.errors.DataError
        The Riccati equation has no stabilising solution for this noise model.
    """
    A, C = model.A, model.C
    Q, R = noise.covariances(model)
    try:
        P = linalg.solve_discrete_are(A.T, C.T, Q, R)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise DataError("virtual", f"no steady-state Kalman filter for this noise model "
                        f"({exc}): give every motor torque and load a noise > 0") from exc
    P = 0.5 * (P + P.T)
    S = C @ P @ C.T + R
    K = linalg.solve(S, C @ P, assume_a="pos").T
    Pf = P - K @ C @ P
    Pf = 0.5 * (Pf + Pf.T)
    # G = Pf Aᵀ P⁻¹ (P and Pf symmetric), P equilibrated first: its states mix rad and
    # rad/s and N·m, diagonal entries decades apart
    d = np.sqrt(np.diag(P))
    scale = np.outer(d, d)
    G = ((linalg.pinvh(P / scale) @ ((A @ Pf) / d[:, None])) / d[:, None]).T
    # Ps = G Ps Gᵀ + (Pf − G P Gᵀ) in the same equilibrated coordinates (Ps = D X D, D =
    # diag d): unscaled, the Kronecker system I − G⊗G that scipy solves mixes entries
    # decades apart (rcond 5e-23 on a 4-disk chain, a LinAlgWarning) although G's spectral
    # radius is 0.98 there; scaled, its rcond is 8e-6
    Ps = linalg.solve_discrete_lyapunov(G * d / d[:, None], (Pf - G @ P @ G.T) / scale) * scale
    return Gains(P, Pf, 0.5 * (Ps + Ps.T), K, S, A - A @ K @ C, G)


def _free_response(C: np.ndarray, Phi: np.ndarray, n_samples: int) -> np.ndarray:
    """``C Φᵏ`` (L, p, n) until it has decayed (L ≤ n_samples), by doubling."""
    rho = max(np.max(np.abs(np.linalg.eigvals(Phi))), 1e-300)
    length = n_samples if rho >= 1 else min(n_samples, int(np.ceil(
        np.log(_DECAYED) / np.log(rho))) + 1)
    p, n = C.shape
    out, power = C, Phi
    # rows stacked (k p, n): one product per doubling
    while out.shape[0] < length * p:
        out = np.vstack([out, out @ power])
        power = power @ power
    return out[:length * p].reshape(length, p, n)


def innovations(model: EstimationModel, g: Gains, y: np.ndarray, u: np.ndarray, *,
                block: int = BLOCK) -> tuple[np.ndarray, np.ndarray, float]:
    """The GLS estimate of ``θ = [x0, b]`` from the innovations, and what is left.

    Parameters
    ----------
    y : ndarray (N, p)
        Measured channels [their units].
    u : ndarray (N, m)
        Motor torques [N·m].
    block : int
        Samples per block of the predictor pass [-] (the memory it holds: the whitened
        innovations of a block, and of the ``L`` samples until ``C Φᵏ`` has decayed).

    Returns
    -------
    theta : ndarray (n + nb,)
    theta_cov : ndarray (n + nb, n + nb)
        Covariance of ``θ`` (pseudo-inverse of the normal matrix; unit noise scale).
    rss : float
        ``Σ eᵀ S⁻¹ e`` [-] of the innovations ``e`` with ``θ`` removed.
    """
    A, C, K, Phi = model.A, model.C, g.K, g.Phi
    n, nb, (N, p) = A.shape[0], model.Gx.shape[1], y.shape
    AK = A @ K
    W = linalg.inv(linalg.cholesky(g.S, lower=True))
    O = _free_response(C, Phi, N)
    L = O.shape[0]
    # the whitened innovations with θ = 0, block by block (an hour at 5 kHz is 18e6
    # samples: ~1 GB per copy of them): those of the first L samples kept, where the
    # regressors R[k] still change; past L, R[k] is the constant rb_inf, so a block's
    # count, mean and sum of squares about its mean are all θ's fit needs (Chan's
    # pairwise update: no cancellation between large sums)
    Bi, Di = np.hstack([AK, model.B - AK @ model.D]), np.hstack([np.eye(p), -model.D])
    head, tail, x = np.empty((L, p)), [], np.zeros(n)
    for k0 in range(0, N, block):
        k1 = min(k0 + block, N)
        we, x = dlsim(Phi, Bi, -C, Di, np.hstack([y[k0:k1], u[k0:k1]]), x,
                      return_state=True)
        we @= W.T
        h = min(max(L - k0, 0), k1 - k0)
        head[k0:k0 + h] = we[:h]
        if h < k1 - k0:
            mean = we[h:].mean(axis=0)
            tail.append((k1 - k0 - h, mean, float(np.sum((we[h:] - mean) ** 2))))
    Gamma = model.Gx - AK @ model.Gy
    H = O @ Gamma
    Rb = model.Gy + np.concatenate([np.zeros((1, p, nb)), np.cumsum(H, axis=0)[:-1]])
    Rt = W @ np.concatenate([O, Rb], axis=2)                 # (L, p, n + nb)
    flat = Rt.reshape(L * p, n + nb)
    normal = flat.T @ flat
    rhs = flat.T @ head.reshape(L * p)
    rb_inf = W @ (model.Gy + C @ linalg.solve(np.eye(n) - Phi, Gamma))
    if tail and nb:
        normal[n:, n:] += (N - L) * rb_inf.T @ rb_inf
        rhs[n:] += rb_inf.T @ np.sum([c * m for c, m, _ in tail], axis=0)
    # scaled by each state's steady uncertainty (and the offsets by their own
    # information) before the pseudo-inverse: a direction of x0 the record does not
    # determine to 1e-8 of the best one is left at 0, never fitted to the noise
    scale = np.concatenate([np.sqrt(np.diag(g.P)), 1 / np.sqrt(np.diag(normal)[n:])])
    cov = linalg.pinvh(normal * np.outer(scale, scale), rtol=_RCOND) * np.outer(scale, scale)
    theta = cov @ rhs
    head -= Rt @ theta
    fitted = rb_inf @ theta[n:] if nb else np.zeros(p)
    rss = float(np.einsum("ij,ij->", head, head)) + sum(
        ss + c * float(np.sum((m - fitted) ** 2)) for c, m, ss in tail)
    return theta, cov, rss


def smooth(model: EstimationModel, noise: NoiseModel, y: np.ndarray, u: np.ndarray, *,
           block: int = BLOCK) -> Estimate:
    """Smoothed targets and loads of a record, with their standard deviations.

    Everything but the estimates is computed here; the estimates come block by block from
    :meth:`Estimate.blocks` (or whole, :attr:`Estimate.z`).

    Parameters
    ----------
    model : EstimationModel
    noise : NoiseModel
    y : ndarray (N, p)
        Measured channels in ``model.measured`` order [their units]; read again by each
        pass of :meth:`Estimate.blocks`, so not to be changed while it runs.
    u : ndarray (N, m)
        Motor torques in ``model.inputs`` order [N·m] (the same).
    block : int
        Samples per block of the filter and smoother passes [-] (the memory they hold;
        the result is the same for any block, to round-off).
    """
    g = gains(model, noise)
    theta, cov, rss = innovations(model, g, y, u, block=block)
    A, C, K = model.A, model.C, g.K
    n, nb, (N, p) = A.shape[0], model.Gx.shape[1], y.shape
    x0, b = theta[:n], theta[n:]
    Gamma = model.Gx - A @ K @ model.Gy
    # forward: the filtered state x̂f = Cf x̂p + Df w (x0 and the offsets known), output
    # straight as the smoother's drive d[k] = x̂f[k] − G x̂p[k+1], x̂p[k+1] = A x̂f[k] + B u[k]
    # + Gx b: d = (I − G A) x̂f − G B u − G Gx b (one product per sample, not three)
    Bp = np.hstack([A @ K, model.B - A @ K @ model.D, (Gamma @ b)[:, None]])
    Cf = np.eye(n) - K @ C
    Df = np.hstack([K, -K @ model.D, -(K @ model.Gy @ b)[:, None]])
    IGA = np.eye(n) - g.G @ A
    Dd = IGA @ Df - np.hstack([np.zeros((n, p)), g.G @ model.B,
                               (g.G @ model.Gx @ b)[:, None]])
    out = np.vstack([model.Cz, np.eye(n)[model.load_states]])
    dz = np.vstack([model.Dz, np.zeros((len(model.load_states), model.Dz.shape[1]))])

    def drive(k0: int, k1: int, xp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """d[k0:k1] from the predicted state at k0, and the predicted state at k1."""
        w = np.hstack([y[k0:k1], u[k0:k1], np.ones((k1 - k0, 1))])
        return dlsim(g.Phi, Bp, IGA @ Cf, Dd, w, xp, return_state=True)

    def passes() -> Iterator[tuple[int, np.ndarray]]:
        # the filter in blocks, keeping the predicted state at each block's start only;
        # the smoother then runs backward block by block, each block's drive computed
        # again from its start state: the memory of one block, not of the record's
        # states (issue 47) (the last block's drive is kept: the backward pass starts
        # there, and a record of one block is then driven once)
        starts = list(range(0, N - 1, block))
        xp_start, xp = [], x0
        for k0 in starts:
            xp_start.append(xp)
            d, xp = drive(k0, min(k0 + block, N - 1), xp)
        xs = Cf @ xp + Df @ np.concatenate([y[-1], u[-1], [1.0]])   # x̂s[N−1] = x̂f[N−1]
        for k0, xp in zip(starts[::-1], xp_start[::-1], strict=True):
            k1 = min(k0 + block, N - 1)
            if k1 < N - 1:
                d = drive(k0, k1, xp)[0]
            # r[j] = x̂s[k1−j], r[j+1] = G r[j] + d[k1−1−j]: outputs x̂s[k1] .. x̂s[k0+1]
            zk, xs = dlsim(g.G, np.eye(n), out, np.zeros((len(out), n)), d[::-1], xs,
                           return_state=True)
            zk = zk[::-1]
            zk += u[k0 + 1:k1 + 1] @ dz.T
            yield k0 + 1, zk
        yield 0, (out @ xs + dz @ u[0])[None, :]

    var = np.einsum("ij,jk,ik->i", out, g.Ps, out) + (dz * noise.input_sd) ** 2 @ np.ones(
        dz.shape[1])
    scale = rss / (N * p)
    cov_b = cov[n:, n:] * scale
    if nb:
        # the smoother's static gain to an offset error (steady-state responses)
        xp = linalg.solve(np.eye(n) - g.Phi, Gamma)
        xfi = (np.eye(n) - K @ C) @ xp - K @ model.Gy
        xs = linalg.solve(np.eye(n) - g.G, xfi - g.G @ (A @ xfi + model.Gx))
        J = out @ xs
        var = var + np.einsum("ij,jk,ik->i", J, cov_b, J)
    logdet = np.linalg.slogdet(g.S)[1]
    neg2 = N * logdet + N * p * np.log(max(scale, 1e-300)) + N * p
    k = np.arange(N)
    tol = _TRANSIENT * var
    # the GLS covariance at unit scale, as var (the noise model as given)
    start = _transient(out, g.Phi, cov[:n, :n], tol, N)
    end = _transient(out, g.G, g.Pf - g.Ps, tol, N)
    steady = (k >= start) & (N - 1 - k >= end)
    return Estimate(np.sqrt(var), b, np.sqrt(np.diag(cov_b)), float(neg2), float(scale),
                    steady, passes)


def _transient(out: np.ndarray, m: np.ndarray, excess: np.ndarray, tol: np.ndarray,
               n_samples: int) -> int:
    """Samples until ``diag(out mᵏ excess mᵏᵀ outᵀ)`` stays at or below ``tol`` (every
    output) for good: the steps of the covariance recursion ``D ← m D mᵀ`` (module
    docstring of ``Estimate.steady``), evaluated every ``step`` samples."""
    step = max(1, int(np.ceil(n_samples / _GRID)))
    o = _free_response(out, np.linalg.matrix_power(m, step), int(np.ceil(n_samples / step)))
    hits = np.flatnonzero(np.any(np.sum((o @ excess) * o, axis=2) > tol, axis=1))
    return 0 if hits.size == 0 else min(n_samples, int(hits[-1] + 1) * step)
