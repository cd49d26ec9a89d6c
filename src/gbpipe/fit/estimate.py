"""Fit physical config parameters (inertias, stiffnesses, damping, gains) to FRFs or modes.

Residuals: for every FRF value, ``ln|G_model/G_data|`` [Np] and the wrapped phase
``∠(G_model/G_data)`` [rad], each divided by the value's standard deviation
(:mod:`gbpipe.fit.residuals`); or, from a modal table, each mode's frequency and
damping error over its spread (:mod:`gbpipe.fit.modes`). Unknowns:
``θ = ln(p / p_prior)`` within bounds (:class:`gbpipe.fit.parameters.FreeParameters`).
Resonance fitting has local minima, so a global stage (Latin-hypercube starts, and
differential evolution unless a start fits exact data to round-off: :mod:`gbpipe.fit.search`)
precedes the local least squares. At the best optimum the Jacobian decides what the data
determine (:mod:`gbpipe.fit.identifiability`): a parameter of an undetermined direction
is fixed at its prior and the others are fitted again, so the model still reproduces the
data and no undetermined number is reported as fitted. A chi-square test of the final
residuals against the data's bounds (:mod:`gbpipe.fit.goodness`) says whether the model
explains the data at all: a determined parameter of a fit that fails it is ``poor``, never
``identified``.

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

from gbpipe.errors import ConfigError, DataError
from gbpipe.fit.frf_data import FrfData
from gbpipe.fit.goodness import DEFAULT_ALPHA, POOR, UNTESTED, Goodness, chi_square_test
from gbpipe.fit.identifiability import Z95, Identifiability, analyse, describe_direction
from gbpipe.fit.keypath import overlay
from gbpipe.fit.modes import ModalData, ModalResiduals, ModeTable
from gbpipe.fit.parameters import DEFAULT_FACTOR, FreeParameters
from gbpipe.fit.residuals import DELAY_UNIT, FrfResiduals, correlation_factor
from gbpipe.fit.search import SEARCHES, evolution_run, local_run, needs_evolution, start_runs

__all__ = ["FitResult", "fit_parameters", "correlation_factor", "DELAY_NAME",
           "DEFAULT_ACCURACY"]

#: Name of the delay unknown in the identifiability analysis; its unit in ``θ`` is 1 ms.
DELAY_NAME = "delay"

#: Parameter statuses: determined and the fit passed its chi-square test; determined but
#: the fit is poor; determined but the fit could not be tested (no sigma: ``fit.weight:
#: uniform``, or no degrees of freedom left), so nothing says the model fits within the
#: data's errors; fitted with an undetermined partner held, or known only to worse than
#: ``accuracy``; held at prior.
IDENTIFIED, POOR_FIT, UNTESTED_FIT, CONDITIONAL, UNIDENTIFIABLE = (
    "identified", "poor", "untested", "conditional", "unidentifiable")
#: Default relative half-width of a 95 % interval that still counts as identified: the
#: issue's "each identifiable parameter within 5 %" (a parameter known only to ±20 % is a
#: combination the data leave open, not a result). ``fit.accuracy`` sets it.
DEFAULT_ACCURACY = 0.05


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
        95 % interval of each determined parameter: ``identified``, or ``poor`` (then it
        assumes a model the data reject); NaN otherwise.
    status : list of str
        ``identified`` (determined, and the fit passed its goodness test or had no sigma
        to test against); ``poor`` (determined, but the fit failed the test: its interval
        assumes a model the data reject); ``unidentifiable`` (fixed at its prior);
        ``conditional`` (fitted with an undetermined partner held at its prior, or in a
        direction the data determine only to worse than ``accuracy``: its value is one
        point of a family the data cannot tell apart to that accuracy, so it gets no
        interval).
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
        :func:`gbpipe.fit.bands.jackknife_intervals` widened them.
    goodness : Goodness
        The chi-square test of the final residuals (:mod:`gbpipe.fit.goodness`).
    search : str
        The global stages run: ``starts`` or ``starts + evolution``.
    modes : ModeTable or None
        For a fit to a modal table: data, prior and fitted modes, mode by mode.
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
    goodness: Goodness = field(repr=False)
    search: str = "starts"
    modes: ModeTable | None = None
    interval_method: str = "fisher"

    @property
    def identified(self) -> np.ndarray:
        """Per parameter: determined by the data, and the fit passed its test."""
        return np.array([s == IDENTIFIED for s in self.status])

    @property
    def determined(self) -> np.ndarray:
        """Per parameter: determined by the data (``identified``, ``poor`` or
        ``untested``)."""
        return np.array([s in (IDENTIFIED, POOR_FIT, UNTESTED_FIT) for s in self.status])

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
        lines.append(f"goodness of fit: {self.goodness.status} ({self.goodness.reason})")
        if self.modes is not None:
            lines.append(self.modes.text())
        return "\n".join(lines + [f"cannot separate: {c}" for c in self.combinations])


def _residuals(fp: FreeParameters, data: Sequence[FrfData] | ModalData,
               delay: bool) -> FrfResiduals | ModalResiduals:
    """The residual set of the data: FRFs, or a modal table."""
    if isinstance(data, ModalData):
        if delay:
            raise ConfigError("fit.delay", "a modal table has no phase to carry a delay: "
                                           "set fit.delay: false")
        return ModalResiduals(fp, data)
    if not data:
        raise DataError("fit data", "give at least one FRF")
    if len({d.sigma is None for d in data}) > 1:
        raise DataError("fit data", "give sigma for every FRF or for none")
    return FrfResiduals(fp, data, delay)


def _weak_directions(weak: Identifiability, accuracy: float, involvement: float) -> list[str]:
    """In words: each direction the data determine only to worse than ``±accuracy``."""
    out = []
    for k in np.nonzero(~weak.determined)[0][::-1]:
        v = weak.directions[:, k]
        # the direction's 95 % half-width in θ, as a relative factor
        pm = 100 * np.expm1(Z95 * weak.noise_scale / max(weak.singular_values[k], 1e-300))
        tail = (f"known only to ±{pm:.3g} % (95 %), worse than fit.accuracy "
                f"±{100 * accuracy:g} %: conditional")
        idx = [i for i in np.argsort(-np.abs(v)) if abs(v[i]) >= involvement]
        if len(idx) == 1:
            out.append(f"`{weak.names[idx[0]]}` is {tail}")
        else:
            # the sentence of a direction names what the data see; along it they see little
            out.append(f"{describe_direction(v, weak.names, involvement)}; along the other "
                       f"combination {tail}")
    return out


def _goodness(problem: FrfResiduals | ModalResiduals, theta: np.ndarray, n_unknowns: int,
              alpha: float) -> Goodness:
    r = problem.residual(theta)
    return chi_square_test(r, n_unknowns, correlation_factor(r, problem.sequences),
                           problem.groups, problem.frequency, problem.has_sigma, alpha)


def fit_parameters(cfg: Mapping[str, Any], data: Sequence[FrfData] | ModalData,
                   free: Sequence[str], *,
                   bounds: Mapping[str, tuple[float, float]] | None = None,
                   factor: float = DEFAULT_FACTOR, n_starts: int = 4,
                   n_global: int | None = None, seed: int = 0, noise_floor: float = 1e-3,
                   rtol: float = 1e-6, max_sd: float = 0.2, involvement: float = 0.1,
                   accuracy: float = DEFAULT_ACCURACY,
                   delay: bool = False, max_delay: float = 1e-3, search: str = "auto",
                   alpha: float = DEFAULT_ALPHA) -> FitResult:
    """Fit config parameters to FRFs or a modal table; say what the data determine and
    whether the model explains them.

    Parameters
    ----------
    cfg : mapping
        Validated configuration: the prior, and the start of the fit.
    data : sequence of FrfData, or ModalData
        The FRFs (one per pairing; grids may differ; either all carry ``sigma`` or none),
        or identified modes with their spreads (:class:`gbpipe.fit.modes.ModalData`).
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
        Seed of the Latin hypercube and of the differential evolution.
    noise_floor : float, default 1e-3
        Smallest residual scale [Np, rad] assumed when the data carry no sigma: clean
        simulated data would otherwise claim infinite precision.
        With sigma, the scale is ``max(1, residual rms)``: a confidence band carries an
        estimate's scatter, not its bias, and intervals widen when the residuals exceed
        it (the Birge ratio).
    rtol, max_sd, involvement : float
        Identifiability thresholds of :func:`gbpipe.fit.identifiability.analyse`: a
        direction below them is undetermined and one of its parameters held at its prior.
    accuracy : float, default 0.05
        Largest relative half-width of an identified parameter's 95 % interval [1]. A
        direction the data determine, but only to worse than ``ln(1 + accuracy)/1.96``
        in ``θ``, is weak: its parameters keep their fitted values (holding them at the
        prior would leave the data unexplained) but are ``conditional``, without an
        interval, and the combination is named; so every ``identified`` parameter is
        known to ``±accuracy`` (before any jackknife widening).
    delay : bool, default False
        Also fit an input-to-output time delay [s] (the measurement chain's latency; FRFs
        only).
    max_delay : float, default 1e-3
        Bound of the delay [s]: ``-max_delay … max_delay``.
    search : {"auto", "starts", "evolution"}, default "auto"
        Global stage (:data:`gbpipe.fit.search.SEARCHES`): the starts; the starts,
        then differential evolution unless the best start fits to round-off; or both
        always.
    alpha : float, default 0.01
        Level of the goodness-of-fit test (:func:`gbpipe.fit.goodness.chi_square_test`).

    Returns
    -------
    FitResult

    Raises
    ------
    ConfigError
        A bad key path, prior, bound, search or level; a delay with a modal table.
    DataError
        No data, some data with sigma and some without, or fewer residuals than free
        parameters.
    """
    if search not in SEARCHES:
        raise ConfigError("fit.search", f"'{search}' is not one of {list(SEARCHES)}")
    if not 0 < alpha < 1:
        raise ConfigError("fit.alpha", f"{alpha} must lie in (0, 1)")
    if not accuracy > 0:
        raise ConfigError("fit.accuracy", f"{accuracy} must be > 0 (a relative half-width)")
    if delay and not max_delay > 0:
        raise ConfigError("fit.max_delay", f"{max_delay} s must be > 0")
    fp = FreeParameters.from_config(cfg, free, bounds, factor)
    problem = _residuals(fp, data, delay)
    n = len(fp.paths)
    lo, hi = fp.log_bounds
    names = list(fp.paths)
    if delay:       # one more unknown: the delay in ms, around 0
        lo, hi = np.append(lo, -max_delay / DELAY_UNIT), np.append(hi, max_delay / DELAY_UNIT)
        names.append(DELAY_NAME)
    nu = lo.size
    if problem.size <= nu:
        raise DataError("fit data", f"{problem.size} residuals for {nu} unknowns: "
                                    "give more frequencies (modes) or fewer parameters")
    everything = np.ones(nu, dtype=bool)
    theta0 = np.zeros(nu)
    cost_prior = 0.5 * float(np.sum(problem.residual(theta0) ** 2))
    runs = start_runs(problem, lo, hi, n_starts, 8 * nu if n_global is None else n_global,
                      seed)
    theta, cost = min(runs, key=lambda r: r[1])
    how = "starts"
    if needs_evolution(search, cost, cost_prior):
        # the starts may all have fallen into one wrong basin: cover the box
        runs.append(evolution_run(problem, lo, hi, seed))
        theta, cost = min(runs, key=lambda r: r[1])
        how = "starts + evolution"
    if isinstance(problem, FrfResiduals):
        # the window-kernel rule was refined at the prior; the optimum's modes may sit
        # elsewhere: refine it there too and polish the optimum on the refined rule
        refined = problem.refined(theta)
        if refined is not problem:
            problem = refined
            cost_prior = 0.5 * float(np.sum(problem.residual(theta0) ** 2))
            theta, cost = local_run(problem, theta, everything, lo, hi)

    m = problem.size
    rms = np.sqrt(2 * cost / max(m - nu, 1))
    scale = max(rms, 1.0) if problem.has_sigma else max(rms, noise_floor)
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
        theta = local_run(problem, theta, active, lo, hi)[0]
        final = analyse(problem.jacobian(theta)[:, active],
                        [names[i] for i in np.nonzero(active)[0]],
                        scale, rtol, max_sd, involvement)
        flagged[active] |= final.flagged

    goodness = _goodness(problem, theta, int(active.sum()), alpha)
    determined_status = {POOR: POOR_FIT, UNTESTED: UNTESTED_FIT}.get(goodness.status,
                                                                      IDENTIFIED)
    # determined, but weakly: a direction known only to worse than ±accuracy (95 %)
    # (the structural ones are held above; these keep their fitted values: the data do
    # move them off the prior, only not to the accuracy asked)
    # (a poor fit identifies nothing anyway: its determined parameters stay ``poor``, their
    # Birge-widened intervals are no measure of what the data would determine)
    combinations = list(first.combinations)
    if active.any() and determined_status != POOR_FIT:
        half = float(np.log1p(accuracy))
        weak = analyse(problem.jacobian(theta)[:, active],
                       [names[i] for i in np.nonzero(active)[0]], scale, rtol, half / Z95,
                       involvement)
        flagged[active] |= weak.flagged | (Z95 * final.sd > half)
        combinations += _weak_directions(weak, accuracy, involvement)
    status = [UNIDENTIFIABLE if not active[i] else CONDITIONAL if flagged[i]
              else determined_status for i in range(nu)]
    ident = np.array([s == determined_status for s in status])
    sd, corr = np.full(nu, np.nan), np.full((nu, nu), np.nan)
    if active.any():
        sd[active] = final.sd
        corr[np.ix_(active, active)] = final.correlation
    sd[~ident] = np.nan
    corr[~ident] = np.nan
    corr[:, ~ident] = np.nan
    interval = fp.values(theta[:n])[:, None] * np.exp(np.outer(sd[:n], [-Z95, Z95]))
    tau = float(theta[n]) * DELAY_UNIT if delay else 0.0
    tau_iv = (tau + np.array([-Z95, Z95]) * sd[n] * DELAY_UNIT if delay
              else np.full(2, np.nan))
    residual = problem.residual(theta)
    modes = problem.table(theta0, theta) if isinstance(problem, ModalResiduals) else None
    return FitResult(fp.paths, fp.prior, fp.values(theta[:n]), interval, status[:n],
                     corr[:n, :n], combinations, first, cost_prior,
                     0.5 * float(residual @ residual), residual, float(scale),
                     np.array([r[1] for r in runs]), problem.n_evaluations, tau, tau_iv,
                     fp.config(theta[:n]), goodness, how, modes)
