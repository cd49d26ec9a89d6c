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
See docs/fit.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import qmc

from gbpipe.errors import DataError
from gbpipe.model.frf_data import FrfData
from gbpipe.model.identifiability import Z95, Identifiability, analyse, log_jacobian
from gbpipe.model.keypath import overlay
from gbpipe.model.parameters import DEFAULT_FACTOR, FreeParameters

__all__ = ["FitResult", "fit_parameters"]

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
        Final cost of each local start (the spread shows the local minima).
    n_evaluations : int
        Model evaluations (each: every pairing on every frequency).
    config : dict
        The configuration with the fitted values.
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
    config: dict[str, Any] = field(repr=False)

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
        return "\n".join(lines + [f"cannot separate: {c}" for c in self.combinations])


class _Problem:
    """Weighted residuals of a subset of the free parameters (the others held)."""

    def __init__(self, free: FreeParameters, data: Sequence[FrfData]) -> None:
        self.free = free
        self.response = free.response([d.pairing for d in data], [d.f_hz for d in data])
        self.mask = np.concatenate([d.mask.ravel() for d in data])
        self.target = np.concatenate([d.frf.ravel() for d in data])[self.mask]
        w = np.concatenate([d.weight for d in data])
        self.weight = np.concatenate([w, w])
        self.n_evaluations = 0

    def values(self, theta: np.ndarray) -> np.ndarray:
        self.n_evaluations += 1
        return self.response(theta)[self.mask]

    def residual(self, theta: np.ndarray) -> np.ndarray:
        r = np.log(self.values(theta) / self.target)    # Np + j·rad, phase wrapped
        return self.weight * np.concatenate([r.real, r.imag])

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        return self.weight[:, None] * log_jacobian(self.values, theta)


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
                   rtol: float = 1e-6, max_sd: float = 0.2, involvement: float = 0.1
                   ) -> FitResult:
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
        Local runs, from the lowest-cost points among the prior and the global points.
    n_global : int, optional
        Points of the Latin hypercube (default ``8 · n_free``).
    seed : int, default 0
        Seed of the Latin hypercube.
    noise_floor : float, default 1e-3
        Smallest residual scale [Np, rad] assumed when the data carry no sigma: clean
        simulated data would otherwise claim infinite precision.
    rtol, max_sd, involvement : float
        Identifiability thresholds of :func:`gbpipe.model.identifiability.analyse`.

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
    fp = FreeParameters.from_config(cfg, free, bounds, factor)
    problem = _Problem(fp, data)
    lo, hi = fp.log_bounds
    n = lo.size
    if problem.weight.size <= n:
        raise DataError("fit data", f"{problem.weight.size} residuals for {n} free "
                                    "parameters: give more frequencies or fewer parameters")
    everything = np.ones(n, dtype=bool)
    theta0 = np.zeros(n)
    cost_prior = 0.5 * float(np.sum(problem.residual(theta0) ** 2))
    runs = [_local(problem, s, everything, lo, hi)
            for s in _starts(problem, lo, hi, n_starts, 8 * n if n_global is None
                             else n_global, seed)]
    theta, cost = min(runs, key=lambda r: r[1])

    m = problem.weight.size
    scale = 1.0 if data[0].sigma is not None else max(
        np.sqrt(2 * cost / max(m - n, 1)), noise_floor)
    first = analyse(problem.jacobian(theta), fp.paths, scale, rtol, max_sd, involvement)

    # fix one parameter per undetermined direction (the one it moves most), refit the rest
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
        final = analyse(problem.jacobian(theta)[:, active], [fp.paths[i] for i in
                                                             np.nonzero(active)[0]],
                        scale, rtol, max_sd, involvement)
        flagged[active] |= final.flagged

    status = [UNIDENTIFIABLE if not active[i] else CONDITIONAL if flagged[i]
              else IDENTIFIED for i in range(n)]
    ident = np.array([s == IDENTIFIED for s in status])
    sd, corr = np.full(n, np.nan), np.full((n, n), np.nan)
    if active.any():
        sd[active] = final.sd
        corr[np.ix_(active, active)] = final.correlation
    sd[~ident] = np.nan
    corr[~ident] = np.nan
    corr[:, ~ident] = np.nan
    interval = fp.values(theta)[:, None] * np.exp(np.outer(sd, [-Z95, Z95]))
    residual = problem.residual(theta)
    return FitResult(fp.paths, fp.prior, fp.values(theta), interval, status, corr,
                     first.combinations, first, cost_prior, 0.5 * float(residual @ residual),
                     residual,
                     float(scale), np.array([r[1] for r in runs]), problem.n_evaluations,
                     fp.config(theta))
