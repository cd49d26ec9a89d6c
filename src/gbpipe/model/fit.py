"""Fit physical config parameters (inertias, stiffnesses, damping, gains) to FRFs.

Residuals: for every FRF value, ``ln|G_model/G_data|`` [Np] and the wrapped phase
``∠(G_model/G_data)`` [rad], each divided by the value's standard deviation
(:class:`gbpipe.model.frf_data.FrfData`). Unknowns: ``θ = ln(p / p_prior)`` within bounds
(:class:`gbpipe.model.parameters.FreeParameters`). Resonance fitting has local minima,
so a coarse global stage (the prior and a Latin hypercube over the bounds, one model
evaluation per point) ranks the points by cost, and ``scipy.optimize.least_squares``
(trust-region reflective) starts from the best few. At the best optimum the
Jacobian decides what the data determine (:mod:`gbpipe.model.identifiability`): a
parameter of an undetermined direction is fixed at its prior and the others are fitted
again, so the model still reproduces the data and no undetermined number is reported as
fitted. The model is evaluated by the batched FRF of :mod:`gbpipe.model.frf`.

A measured FRF also carries the measurement chain's latency: a time delay ``τ`` between the
input and the output channel (a data-acquisition or sensor delay; on a simulated record
half a sample of the zero-order hold, 0.1 ms at 5 kHz, which is -10° at 290 Hz). Left out,
it is absorbed by the stiffnesses and inertias (1.8 % on the default bench); with
``delay=True`` it is one more unknown, ``G_model·exp(-jωτ)``, fitted in milliseconds.
See docs/fit.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import qmc

from gbpipe.errors import ConfigError, DataError
from gbpipe.model.frf_data import FrfData
from gbpipe.model.identifiability import Z95, Identifiability, analyse, log_jacobian
from gbpipe.model.keypath import overlay
from gbpipe.model.parameters import DEFAULT_FACTOR, FreeParameters

__all__ = ["FitResult", "fit_parameters", "correlation_factor", "DELAY_NAME"]

#: Name of the delay unknown in the identifiability analysis; its unit in ``θ`` is 1 ms.
DELAY_NAME = "delay"
_DELAY_UNIT = 1e-3      # s: one step in θ of the delay
#: Relative cost difference below which two local runs ended in the same minimum.
_SAME_COST = 1e-6

IDENTIFIED, CONDITIONAL, UNIDENTIFIABLE = "identified", "conditional", "unidentifiable"


@dataclass
class FitResult:
    """Fitted parameters, what the data determine, and how well the model fits.

    Attributes
    ----------
    free : list of str
        Key paths of the free parameters.
    prior, value : ndarray
        Start and fitted values (units of each key). ``value`` equals ``prior`` for an
        ``unidentifiable`` parameter.
    interval : ndarray, shape (n, 2)
        95 % interval of each ``identified`` parameter (NaN otherwise).
    status : list of str
        ``identified``; ``unidentifiable`` (fixed at its prior); ``conditional`` (fitted
        with an undetermined partner held at its prior: its value is one point of a
        family the data cannot tell apart, so it gets no interval).
    correlation : ndarray, shape (n, n)
        Correlation of the identified parameters' log-values (NaN elsewhere).
    combinations : list of str
        What the data cannot separate, in words.
    identifiability : Identifiability
        The analysis over all free parameters at the unconstrained optimum.
    cost_prior, cost : float
        ½ Σ r² of the weighted residuals at the prior and at the fit.
    residual : ndarray
        Weighted residuals at the fit: log-magnitudes, then phases.
    noise_scale : float
        Standard deviation of a weighted residual used for the intervals (1 when the data
        carry their sigma; else the residual rms, at least ``noise_floor``).
    start_costs : ndarray
        Final cost of each local start run (the spread shows the local minima; fewer than
        ``n_starts`` when two runs agreed early).
    n_evaluations : int
        Model evaluations (each: every pairing on every frequency).
    delay, delay_interval : float, ndarray of shape (2,)
        Fitted input-to-output delay [s] and its 95 % interval (0 and NaN when not fitted).
    config : dict
        The configuration with the fitted values.
    interval_method : str
        ``fisher`` (from the Jacobian), or ``jackknife over n bands`` when
        :func:`gbpipe.model.fit_bands.jackknife_intervals` widened them.
    """

    free: list[str]
    prior: np.ndarray
    value: np.ndarray
    interval: np.ndarray
    status: list[str]
    correlation: np.ndarray
    combinations: list[str]
    identifiability: Identifiability
    cost_prior: float
    cost: float
    residual: np.ndarray
    noise_scale: float
    start_costs: np.ndarray
    n_evaluations: int
    delay: float
    delay_interval: np.ndarray
    config: dict[str, Any] = field(repr=False)
    interval_method: str = "fisher"

    @property
    def identified(self) -> np.ndarray:
        """Per parameter: determined by the data."""
        return np.array([s == IDENTIFIED for s in self.status])

    def overlay(self) -> dict[str, Any]:
        """The fitted free parameters as a config overlay (nested keys, whole lists)."""
        return overlay(self.config, self.free)

    def table(self) -> str:
        """A plain-text table: key path, prior, fitted value, 95 % interval, status."""
        lines = [f"{'parameter':32s} {'prior':>11s} {'fitted':>11s} {'95 % interval':>25s}"
                 "  status"]
        for i, p in enumerate(self.free):
            lo, hi = self.interval[i]
            iv = f"[{lo:.4g}, {hi:.4g}]" if np.isfinite(lo) else "–"
            lines.append(f"{p:32s} {self.prior[i]:11.4g} {self.value[i]:11.4g} {iv:>25s}"
                         f"  {self.status[i]}")
        if np.isfinite(self.delay_interval[0]):
            lo, hi = self.delay_interval * 1e3
            lines.append(f"{'delay [ms]':32s} {0.0:11.4g} {self.delay * 1e3:11.4g} "
                         f"{f'[{lo:.4g}, {hi:.4g}]':>25s}  fitted")
        return "\n".join(lines + [f"cannot separate: {c}" for c in self.combinations])


class _Problem:
    """Weighted residuals of a subset of the free parameters (the others held)."""

    def __init__(self, free: FreeParameters, data: Sequence[FrfData], delay: bool) -> None:
        self.free = free
        self.n = len(free.paths)
        self.response = free.response([d.pairing for d in data], [d.f_hz for d in data])
        self.mask = np.concatenate([d.mask.ravel() for d in data])
        # angular frequency of every fitted value, in rad per ms (θ's delay unit)
        omega = np.concatenate([np.broadcast_to(d.f_hz[:, None, None], d.frf.shape).ravel()
                                for d in data])[self.mask] * 2 * np.pi * _DELAY_UNIT
        self.delay_phase = omega if delay else None
        # one label per FRF element (pairing, output, input): the residuals of one element
        # along frequency form a sequence whose correlation the intervals account for
        labels, first = [], 0
        for d in data:
            elements = np.arange(d.frf[0].size).reshape(d.frf.shape[1:])
            labels.append(np.broadcast_to(elements, d.frf.shape).ravel() + first)
            first += d.frf[0].size
        element = np.concatenate(labels)[self.mask]
        self.sequences = np.concatenate([element, element + first])     # real, then imag
        self.target = np.concatenate([d.frf.ravel() for d in data])[self.mask]
        w = np.concatenate([d.weight for d in data])
        self.weight = np.concatenate([w, w])
        self.n_evaluations = 0

    def values(self, theta: np.ndarray) -> np.ndarray:
        self.n_evaluations += 1
        g = self.response(theta[:self.n])[self.mask]
        if self.delay_phase is None:
            return g
        return g * np.exp(-1j * self.delay_phase * theta[self.n])

    def residual(self, theta: np.ndarray) -> np.ndarray:
        r = np.log(self.values(theta) / self.target)    # Np + j·rad, phase wrapped
        return self.weight * np.concatenate([r.real, r.imag])

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        return self.weight[:, None] * log_jacobian(self.values, theta)


def correlation_factor(residual: np.ndarray, sequences: np.ndarray) -> float:
    """Variance inflation of a mean of residuals that are correlated along frequency.

    A model error is smooth in frequency, so neighbouring residuals are not independent
    and ``JᵀJ/s²`` overstates the information. The factor ``1 + 2 Σ ρ_k`` (the ratio of
    the long-run to the plain variance) uses the autocorrelation ``ρ_k`` at lag ``k``
    pooled over the sequences (one per FRF element and real/imaginary part, in frequency
    order) and summed up to the first lag at which it is no longer positive (Geyer's
    initial positive sequence).

    Parameters
    ----------
    residual : ndarray
        Weighted residuals.
    sequences : ndarray of int
        Sequence label of each residual (its members in frequency order).

    Returns
    -------
    float
        At least 1.
    """
    r = residual - residual.mean()
    groups = [r[sequences == g] for g in np.unique(sequences)]
    c0 = sum(float(g @ g) for g in groups)
    if c0 <= 0:
        return 1.0
    total = 0.0
    for k in range(1, max(g.size for g in groups)):
        rho = sum(float(g[:-k] @ g[k:]) for g in groups if g.size > k) / c0
        if rho <= 0:
            break
        total += rho
    return 1.0 + 2.0 * total


def _embed(theta: np.ndarray, sub: np.ndarray, active: np.ndarray) -> np.ndarray:
    out = theta.copy()
    out[active] = sub
    return out


def _local(problem: _Problem, theta: np.ndarray, active: np.ndarray,
           lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, float]:
    """One trust-region least-squares run over the active parameters from ``theta``."""
    sol = least_squares(lambda s: problem.residual(_embed(theta, s, active)),
                        np.clip(theta[active], lo[active], hi[active]),
                        bounds=(lo[active], hi[active]), method="trf", x_scale=1.0,
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=100 * int(active.sum()))
    return _embed(theta, sol.x, active), float(sol.cost)


def _starts(problem: _Problem, lo: np.ndarray, hi: np.ndarray, n_starts: int,
            n_global: int, seed: int) -> list[np.ndarray]:
    """The ``n_starts`` lowest-cost points among the prior and a Latin hypercube."""
    pts = np.zeros((1, lo.size))
    if n_global > 0:
        lhs = qmc.LatinHypercube(d=lo.size, seed=seed).random(n_global)
        pts = np.vstack([pts, qmc.scale(lhs, lo, hi)])
    cost = [0.5 * np.sum(problem.residual(p) ** 2) for p in pts]
    return [pts[i] for i in np.argsort(cost, kind="stable")[:max(n_starts, 1)]]


def fit_parameters(cfg: Mapping[str, Any], data: Sequence[FrfData], free: Sequence[str], *,
                   bounds: Mapping[str, tuple[float, float]] | None = None,
                   factor: float = DEFAULT_FACTOR, n_starts: int = 4,
                   n_global: int | None = None, seed: int = 0, noise_floor: float = 1e-3,
                   rtol: float = 1e-6, max_sd: float = 0.2, involvement: float = 0.1,
                   delay: bool = False, max_delay: float = 1e-3) -> FitResult:
    """Fit config parameters to one or more FRFs, and say what the data determine.

    Parameters
    ----------
    cfg : mapping
        Validated configuration: the prior, and the start of the fit.
    data : sequence of FrfData
        The FRFs (one per pairing; grids may differ). Either all carry ``sigma`` or none.
    free : sequence of str
        Key paths of the free numbers, e.g. ``"gearbox.stiffness[1]"``,
        ``"gearbox.housing.stiffness"``, ``"bench.coupling.stiffness"``.
    bounds : mapping, optional
        Key path -> (lower, upper) in the key's unit.
    factor : float, default 3
        Bounds ``prior / factor … prior · factor`` of the other parameters.
    n_starts : int, default 4
        Local runs at most, from the lowest-cost points among the prior and the global
        points; they stop early once two runs end at the same lowest cost.
    n_global : int, optional
        Points of the Latin hypercube (default ``8 · n_free``).
    seed : int, default 0
        Seed of the Latin hypercube.
    noise_floor : float, default 1e-3
        Smallest residual scale [Np, rad] assumed when the data carry no sigma: clean
        simulated data would otherwise claim infinite precision.
        With sigma, the scale is ``max(1, residual rms)``: a confidence band carries an
        estimate's scatter, not its bias, and intervals widen when the residuals exceed
        it (the Birge ratio).
    rtol, max_sd, involvement : float
        Identifiability thresholds of :func:`gbpipe.model.identifiability.analyse`.
    delay : bool, default False
        Also fit an input-to-output time delay [s] (the measurement chain's latency).
    max_delay : float, default 1e-3
        Bound of the delay [s]: ``-max_delay … max_delay``.

    Returns
    -------
    FitResult

    Raises
    ------
    ConfigError
        A bad key path, prior or bound (:class:`FreeParameters`).
    DataError
        No data, some data with sigma and some without, or fewer residuals than free
        parameters.
    """
    if not data:
        raise DataError("fit data", "give at least one FRF")
    if len({d.sigma is None for d in data}) > 1:
        raise DataError("fit data", "give sigma for every FRF or for none")
    if delay and not max_delay > 0:
        raise ConfigError("fit.max_delay", f"{max_delay} s must be > 0")
    fp = FreeParameters.from_config(cfg, free, bounds, factor)
    problem = _Problem(fp, data, delay)
    n = len(fp.paths)
    lo, hi = fp.log_bounds
    names = list(fp.paths)
    if delay:       # one more unknown: the delay in ms, around 0
        lo, hi = np.append(lo, -max_delay / _DELAY_UNIT), np.append(hi, max_delay / _DELAY_UNIT)
        names.append(DELAY_NAME)
    nu = lo.size
    if problem.weight.size <= nu:
        raise DataError("fit data", f"{problem.weight.size} residuals for {nu} unknowns: "
                                    "give more frequencies or fewer parameters")
    everything = np.ones(nu, dtype=bool)
    theta0 = np.zeros(nu)
    cost_prior = 0.5 * float(np.sum(problem.residual(theta0) ** 2))
    runs: list[tuple[np.ndarray, float]] = []
    for start in _starts(problem, lo, hi, n_starts, 8 * nu if n_global is None else n_global,
                         seed):
        runs.append(_local(problem, start, everything, lo, hi))
        # two starts that end at the same lowest cost have found the basin: the remaining
        # starts (ranked worse by the global stage) would only repeat it
        best = min(r[1] for r in runs)
        if sum(r[1] <= best * (1 + _SAME_COST) + 1e-300 for r in runs) >= 2:
            break
    theta, cost = min(runs, key=lambda r: r[1])

    m = problem.weight.size
    rms = np.sqrt(2 * cost / max(m - nu, 1))
    scale = max(rms, 1.0) if data[0].sigma is not None else max(rms, noise_floor)
    # correlated residuals carry less information than their number suggests
    scale *= np.sqrt(correlation_factor(problem.residual(theta), problem.sequences))
    first = analyse(problem.jacobian(theta), names, scale, rtol, max_sd, involvement)

    # fix one unknown per undetermined direction (the one it moves most), refit the rest
    active, final, flagged = everything.copy(), first, first.flagged.copy()
    while not final.determined.all():
        v = final.directions[:, ~final.determined]
        idx = np.nonzero(active)[0]
        for k in range(v.shape[1]):
            active[idx[np.argmax(np.abs(v[:, k]) * active[idx])]] = False
        theta[~active] = 0.0
        if not active.any():
            break
        theta = _local(problem, theta, active, lo, hi)[0]
        final = analyse(problem.jacobian(theta)[:, active],
                        [names[i] for i in np.nonzero(active)[0]],
                        scale, rtol, max_sd, involvement)
        flagged[active] |= final.flagged

    status = [UNIDENTIFIABLE if not active[i] else CONDITIONAL if flagged[i]
              else IDENTIFIED for i in range(nu)]
    ident = np.array([s == IDENTIFIED for s in status])
    sd, corr = np.full(nu, np.nan), np.full((nu, nu), np.nan)
    if active.any():
        sd[active] = final.sd
        corr[np.ix_(active, active)] = final.correlation
    sd[~ident] = np.nan
    corr[~ident] = np.nan
    corr[:, ~ident] = np.nan
    interval = fp.values(theta[:n])[:, None] * np.exp(np.outer(sd[:n], [-Z95, Z95]))
    tau = float(theta[n]) * _DELAY_UNIT if delay else 0.0
    tau_iv = (tau + np.array([-Z95, Z95]) * sd[n] * _DELAY_UNIT if delay
              else np.full(2, np.nan))
    residual = problem.residual(theta)
    return FitResult(fp.paths, fp.prior, fp.values(theta[:n]), interval, status[:n],
                     corr[:n, :n], first.combinations, first, cost_prior,
                     0.5 * float(residual @ residual), residual, float(scale),
                     np.array([r[1] for r in runs]), problem.n_evaluations, tau, tau_iv,
                     fp.config(theta[:n]))
