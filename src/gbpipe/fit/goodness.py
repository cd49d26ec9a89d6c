"""Goodness of a physical fit: a chi-square test of its residuals against the data's bounds.

With residuals weighted by the data's standard deviations, a model that explains the data
leaves ``χ² = Σ r²`` near its degrees of freedom. Residuals of FRF values are correlated
along frequency (a model error is smooth; so is what a finite-order identified model
leaves), so ``N`` residuals carry the information of only
``N_eff = N / c`` independent ones, ``c`` the correlation factor the intervals use
(:func:`gbpipe.fit.residuals.correlation_factor`). The test compares ``χ²/c`` with
the chi-square distribution of ``N_eff − n`` degrees of freedom (``n`` fitted unknowns;
Satterthwaite's scaled chi-square). A fit whose ``p`` falls below the level ``alpha`` is
``poor``: the data's bounds do not cover what the model leaves, so its intervals (which
assume they do) are not to be trusted as identification.

Where the misfit sits is reported as each pairing's (or mode's) and each frequency band's
share of ``χ²`` beside its share of the residuals. See docs/fit.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

__all__ = ["Goodness", "chi_square_test", "log_bands", "band_of", "PASSED", "POOR",
           "UNTESTED", "DEFAULT_ALPHA", "N_BANDS"]

PASSED, POOR, UNTESTED = "passed", "poor", "untested"
#: Default level of the test: a fit of a correct model to honest bounds is called poor in
#: 1 % of cases; a misfit of a wrong stiffness or a missing mode gives p ≪ 1e-6, so a
#: lower level would not change the verdict on the misfits that matter, and a higher one
#: would call honest fits poor more often (docs/fit.md).
DEFAULT_ALPHA = 0.01
#: Frequency bands of equal residual count (log axis) over which the misfit is located.
N_BANDS = 8


def log_bands(f_hz: np.ndarray, n_bands: int) -> np.ndarray:
    """Edges [Hz] of ``n_bands`` bands of (nearly) equal count on a log-frequency axis."""
    return np.exp(np.quantile(np.log(np.asarray(f_hz, dtype=float)),
                              np.linspace(0.0, 1.0, n_bands + 1)))


def band_of(f_hz: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Index of the band of :func:`log_bands` each frequency [Hz] falls in."""
    return np.clip(np.searchsorted(edges, f_hz, side="right") - 1, 0, edges.size - 2)


@dataclass
class Goodness:
    """The chi-square test of a fit's weighted residuals.

    Attributes
    ----------
    status : str
        ``passed``, ``poor`` (p < alpha) or ``untested`` (no sigma given, or no degrees
        of freedom left).
    reason : str
        One sentence: the statistic, p, and for a poor fit where the misfit sits.
    chi2, dof, p_value, alpha : float
        ``Σ r²`` [1], effective degrees of freedom ``N/c − n``, its p-value, the level.
    correlation_factor : float
        ``c`` [1].
    groups : list of str
        Pairings (or modes) in the order of the shares.
    group_share, group_count_share : ndarray
        Each group's share of ``χ²`` and of the residuals [1].
    band_edges : ndarray
        Edges [Hz] of the frequency bands.
    band_share, band_count_share : ndarray
        Each band's share of ``χ²`` and of the residuals [1].
    """

    status: str
    reason: str
    chi2: float
    dof: float
    p_value: float
    alpha: float
    correlation_factor: float
    groups: list[str]
    group_share: np.ndarray
    group_count_share: np.ndarray
    band_edges: np.ndarray
    band_share: np.ndarray
    band_count_share: np.ndarray


def chi_square_test(residual: np.ndarray, n_unknowns: int, factor: float,
                    groups: np.ndarray, frequency: np.ndarray, has_sigma: bool = True,
                    alpha: float = DEFAULT_ALPHA, n_bands: int = N_BANDS) -> Goodness:
    """Test weighted residuals against unit variance, with correlated residuals counted.

    Parameters
    ----------
    residual : ndarray
        Residuals, each divided by its data's standard deviation [1].
    n_unknowns : int
        Fitted unknowns (they absorb that many degrees of freedom).
    factor : float
        Correlation factor ``c ≥ 1`` of the residuals along frequency.
    groups : ndarray of str
        Pairing (or mode) of each residual.
    frequency : ndarray
        Frequency [Hz] of each residual.
    has_sigma : bool, default True
        The residuals are weighted by the data's standard deviations; without them there
        is nothing to test against (status ``untested``).
    alpha : float, default 0.01
        Level of the test, in (0, 1).
    n_bands : int, default 8
        Frequency bands over which the misfit is located.

    Returns
    -------
    Goodness
    """
    r2 = np.asarray(residual, dtype=float) ** 2
    total = float(r2.sum())
    names = list(dict.fromkeys(str(g) for g in groups))
    groups = np.asarray(groups).astype(str)
    share = np.array([r2[groups == g].sum() for g in names]) / max(total, 1e-300)
    count = np.array([np.sum(groups == g) for g in names]) / r2.size
    edges = log_bands(frequency, min(n_bands, np.unique(frequency).size))
    band = band_of(frequency, edges)
    nb = edges.size - 1
    b_share = np.bincount(band, weights=r2, minlength=nb) / max(total, 1e-300)
    b_count = np.bincount(band, minlength=nb) / r2.size
    dof = r2.size / factor - n_unknowns
    if not has_sigma or dof <= 0:
        why = ("no sigma given: nothing to test the residuals against" if not has_sigma
               else f"{r2.size} residuals (effective {r2.size / factor:.3g}) for "
                    f"{n_unknowns} unknowns: no degrees of freedom left")
        return Goodness(UNTESTED, why, total, dof, np.nan, alpha, factor, names, share,
                        count, edges, b_share, b_count)
    p = float(chi2.sf(total / factor, dof))
    ratio = total / factor / dof
    head = f"chi2/dof = {ratio:.3g}, p = {p:.2g} (dof {dof:.4g}, correlation factor {factor:.3g})"
    if p >= alpha:
        return Goodness(PASSED, head, total, dof, p, alpha, factor, names, share, count,
                        edges, b_share, b_count)
    # where the misfit sits: the pairing and the band with the largest excess of χ² over
    # their share of the residuals
    g_worst = names[int(np.argmax(share - count))]
    k = int(np.argmax(b_share - b_count))
    reason = (f"{head} < {alpha:g}: misfit in {g_worst} ({100 * share[names.index(g_worst)]:.0f} "
              f"% of chi2), {edges[k]:.3g}–{edges[k + 1]:.3g} Hz ({100 * b_share[k]:.0f} % of "
              "chi2)")
    return Goodness(POOR, reason, total, dof, p, alpha, factor, names, share, count, edges,
                    b_share, b_count)
