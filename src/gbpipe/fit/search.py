"""The search of a physical fit: global starts over the prior box, local least squares.

Resonance fitting has local minima: a model resonance that misses the data's peak sees a
flat cost, and a stiffness that moves a mode past another pairs the wrong peaks. Two
global stages, over the box of the log-parameters ``θ = ln(p / p_prior)``:

* **starts**: the prior and a Latin hypercube (one model evaluation each) ranked by cost;
  ``scipy.optimize.least_squares`` (trust-region reflective) runs from the best few and
  stops once two runs end at the same lowest cost. Two starts that agree do not prove the
  global minimum: a wide wrong basin collects several (the shaft line of
  benchmarks/fit_chain.py, seed 0: two starts at 1.22× the truth's cost, chi-square
  p = 0.088, a coupling −21 % and a torque arm −43 % off);
* **evolution**: ``scipy.optimize.differential_evolution`` (seeded, Latin-hypercube
  population, not seeded with the starts' best) over the box, polished by one
  local run. It covers the box where a few starts may all fall into one wrong basin, at
  about 1500 model evaluations for six parameters.

:func:`gbpipe.fit.estimate.fit_parameters` runs the starts and, with ``search="auto"``,
the evolution too unless the best start fits to round-off (exact data: nothing can beat
a zero cost). Neither the agreement of starts nor a passed chi-square test tells a wrong
basin from the right one (a wrong minimum a few chi-square spreads above the truth
passes), so with the default search (``auto``) a result reported ``identified`` always had
the box covered; ``search="starts"`` (``fit.search: starts``) skips the evolution and
carries no such guarantee. See docs/fit.md.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from scipy.optimize import differential_evolution, least_squares
from scipy.stats import qmc

from gbpipe.progress import Progress

__all__ = ["local_run", "start_runs", "evolution_run", "needs_evolution", "SEARCHES"]

log = logging.getLogger(__name__)

#: Global stages: the starts alone, the starts and the evolution unless the best start fits
#: to round-off, or both always.
SEARCHES = ("starts", "auto", "evolution")
#: Relative cost difference below which two local runs ended in the same minimum.
_SAME_COST = 1e-6
#: Population of the evolution per unknown, and its relative convergence tolerance.
#: Measured on the user's set and 30 random 6-parameter sets of the paper bench
#: (``benchmarks/fit_global.py --sets 30``, docs/fit.md): every fit reached 0.9968-0.9997
#: of the cost at the truth, ~1700 evaluations.
_POPSIZE, _TOL, _MAXITER = 5, 0.01, 60
#: Costs below this share of the prior's are round-off (a perfect fit of exact data).
_ROUND_OFF = 1e-15


def _embed(theta: np.ndarray, sub: np.ndarray, active: np.ndarray) -> np.ndarray:
    out = theta.copy()
    out[active] = sub
    return out


def local_run(problem: Any, theta: np.ndarray, active: np.ndarray, lo: np.ndarray,
              hi: np.ndarray) -> tuple[np.ndarray, float]:
    """One trust-region least-squares run over the active unknowns from ``theta``.

    Parameters
    ----------
    problem : residual set
        With ``residual(θ)`` (:mod:`gbpipe.fit.residuals`).
    theta : ndarray
        Start (all unknowns; the inactive ones are held).
    active : ndarray of bool
        Unknowns that move.
    lo, hi : ndarray
        Bounds of ``θ``.

    Returns
    -------
    theta, cost : ndarray, float
        The optimum and ``½ Σ r²`` there.
    """
    progress = Progress(log, "fit: local least squares, model evaluations")

    def residual(s: np.ndarray) -> np.ndarray:
        progress(problem.n_evaluations)
        return problem.residual(_embed(theta, s, active))

    sol = least_squares(residual,
                        np.clip(theta[active], lo[active], hi[active]),
                        bounds=(lo[active], hi[active]), method="trf", x_scale=1.0,
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=100 * int(active.sum()))
    return _embed(theta, sol.x, active), float(sol.cost)


def needs_evolution(search: str, cost: float, cost_prior: float) -> bool:
    """Whether the evolution runs after the starts.

    Parameters
    ----------
    search : {"starts", "auto", "evolution"}
    cost, cost_prior : float
        ½ Σ r² at the best start's optimum and at the prior.

    Returns
    -------
    bool
        ``evolution``: always; ``starts``: never; ``auto``: unless the best start's cost
        is round-off (``≤ 1e-15`` of the prior's: exact data fitted exactly).
    """
    if search == "auto":
        return cost > _ROUND_OFF * cost_prior
    return search == "evolution"


def _cost(problem: Any, theta: np.ndarray) -> float:
    r = problem.residual(theta)
    return 0.5 * float(r @ r)


def start_runs(problem: Any, lo: np.ndarray, hi: np.ndarray, n_starts: int, n_global: int,
               seed: int) -> list[tuple[np.ndarray, float]]:
    """Local runs from the lowest-cost points among the prior and a Latin hypercube.

    Parameters
    ----------
    problem : residual set
    lo, hi : ndarray
        Bounds of ``θ`` (the prior is ``θ = 0``).
    n_starts : int
        Local runs at most (they stop once two end at the same lowest cost).
    n_global : int
        Latin-hypercube points.
    seed : int
        Seed of the hypercube.

    Returns
    -------
    runs : list of (theta, cost)
        Fewer than ``n_starts`` when two runs ended at the same lowest cost.
    """
    pts = np.zeros((1, lo.size))
    if n_global > 0:
        lhs = qmc.LatinHypercube(d=lo.size, seed=seed).random(n_global)
        pts = np.vstack([pts, qmc.scale(lhs, lo, hi)])
    progress = Progress(log, "fit: costs of the Latin-hypercube starts", len(pts))
    cost = []
    for p in pts:
        cost.append(_cost(problem, p))
        progress(len(cost))
    everything = np.ones(lo.size, dtype=bool)
    runs: list[tuple[np.ndarray, float]] = []
    for i in np.argsort(cost, kind="stable")[:max(n_starts, 1)]:
        runs.append(local_run(problem, pts[i], everything, lo, hi))
        # two starts that end at the same lowest cost have found the basin: the remaining
        # starts (ranked worse by the global stage) would only repeat it
        # (costs at round-off level, ~1e-21 of exact data, agree whatever their ratio)
        best = min(r[1] for r in runs)
        if sum(r[1] <= best * (1 + _SAME_COST) + _ROUND_OFF * cost[0] for r in runs) >= 2:
            break
    return runs


def evolution_run(problem: Any, lo: np.ndarray, hi: np.ndarray,
                  seed: int) -> tuple[np.ndarray, float]:
    """Differential evolution over the box of ``θ``, polished by one local run.

    The population is the box's own Latin hypercube, not seeded with the starts' best: a
    member at a deep wrong minimum pulls the population into its basin before it has
    looked elsewhere (the shaft line's seed 0 with reference-based FRFs: seeded, 2 of 3
    evolutions ended in the starts' wrong basin; unseeded, 4 of 4 found the truth's).
    The caller keeps the lower of this and the starts.

    Parameters
    ----------
    problem : residual set
    lo, hi : ndarray
        Bounds of ``θ``.
    seed : int
        Seed of the evolution.

    Returns
    -------
    theta, cost : ndarray, float
    """
    progress = Progress(log, "fit: differential evolution, generations", _MAXITER)
    generations = iter(range(1, _MAXITER + 2))

    def generation(xk: np.ndarray, convergence: float) -> None:
        progress(next(generations), f"population spread {convergence:.3g} of its stop")

    sol = differential_evolution(lambda th: _cost(problem, th), list(zip(lo, hi, strict=True)),
                                 seed=seed, popsize=_POPSIZE, tol=_TOL, maxiter=_MAXITER,
                                 init="latinhypercube", polish=False, callback=generation)
    return local_run(problem, sol.x, np.ones(lo.size, dtype=bool), lo, hi)
