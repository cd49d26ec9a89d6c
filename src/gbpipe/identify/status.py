"""Honest status of one identified model: ``ok``, ``poor`` or ``failed``, and why.

A row is ``failed`` when no usable model exists (the fit raised, or its validation fit is
not finite); it then carries no bandwidth. A fitted model is ``ok`` only when all three
hold, else ``poor`` with every unmet condition in its reason:

* **stable**: no pole grows faster than the reference's own fastest mode by more than a
  factor 2 over one validation segment (``identify.fit_segment``). A torque -> speed model
  has a rigid-body pole on the unit circle, and with one loop open the bench's 1.3 Hz
  mode is itself unstable (zeta = -0.023, docs/identify.md): a model that reproduces it is
  right, not garbage. A measured record's reference (the nonparametric FRF) has no modes,
  so its models may grow by at most 2 per segment. A factor 2 is where the segment
  simulation of the validation fit starts to be dominated by the growth.
* **fit**: the lowest per-output hold-out fit reaches ``identify.fit_min`` [%].
* **evidence**: the match band (from ``identify.frf.f_min`` up to the match bandwidth)
  holds at least ``identify.min_points`` frequencies the reference can assess. A model
  no better than chance (inside the tolerance at each point with probability 1/2) makes
  ``n`` consecutive hits with probability ``2**-n``: below 0.1 % for the default 10.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

__all__ = ["STATUSES", "Verdict", "growth_rate", "reference_growth_rate", "assess"]

#: Statuses, best first (the rank :func:`gbpipe.identify.best_pairings` sorts by).
STATUSES = ("ok", "poor", "failed")


class Verdict(NamedTuple):
    """Status of one model: ``status`` (one of :data:`STATUSES`), ``reason`` (why; every
    unmet condition of ``ok``), ``stable`` (1.0, 0.0, or NaN when no model exists)."""

    status: str
    reason: str
    stable: float


def growth_rate(a: np.ndarray, dt: float) -> float:
    """Fastest exponential growth rate of a discrete-time state matrix [1/s].

    ``max(ln |z|) / dt`` over its eigenvalues ``z`` (negative for a stable matrix, 0 for
    a pole on the unit circle, ``inf`` for a pole at infinity of a non-finite matrix).
    """
    if a.size == 0:
        return -np.inf
    if not np.all(np.isfinite(a)):
        return np.inf
    with np.errstate(divide="ignore"):
        return float(np.max(np.log(np.abs(np.linalg.eigvals(a)))) / dt)


def reference_growth_rate(frequency_hz: np.ndarray, damping: np.ndarray) -> float:
    """Fastest growth rate of the reference's modes [1/s]: ``max(-zeta 2 pi f)``, at least
    0 (a reference without modes, e.g. a nonparametric estimate, grows at none)."""
    rates = -np.asarray(damping, float) * 2 * np.pi * np.asarray(frequency_hz, float)
    rates = rates[np.isfinite(rates)]
    return float(max(rates.max(initial=0.0), 0.0))


def assess(model: Any, fit: np.ndarray | None, n_points: int, ref_rate: float,
           s: Mapping[str, Any], failure: str | None = None) -> Verdict:
    """Status of one identified model.

    Parameters
    ----------
    model : gbpipe.sysid.SubspaceModel or None
        The fitted model (None: the fit raised).
    fit : ndarray, shape (p,), or None
        Hold-out fit per output [%].
    n_points : int
        Assessable reference frequencies inside the match band.
    ref_rate : float
        Fastest growth rate of the reference [1/s] (:func:`reference_growth_rate`).
    s : mapping
        The validated ``identify`` section (``fit_min``, ``min_points``, ``fit_segment``).
    failure : str, optional
        Why the fit raised (with ``model`` None).

    Returns
    -------
    Verdict
    """
    if model is None:
        return Verdict("failed", failure or "no model", np.nan)
    fit = np.asarray(fit, dtype=float)
    if fit.size == 0 or not np.all(np.isfinite(fit)):
        return Verdict("failed", f"validation fit is not finite "
                       f"({np.round(fit, 1).tolist()} %)", np.nan)
    seg = float(s["fit_segment"])
    excess = growth_rate(model.A, model.dt) - ref_rate
    stable = bool(excess * seg <= np.log(2.0))
    why = []
    if not stable:
        why.append(f"unstable: a pole grows x{np.exp(min(excess * seg, 700.0)):.3g} faster "
                   f"than the reference's modes within one {seg:g} s validation segment "
                   "(at most x2)")
    if float(np.min(fit)) < float(s["fit_min"]):
        why.append(f"hold-out fit {np.min(fit):.1f} % < identify.fit_min "
                   f"{float(s['fit_min']):g} %")
    if n_points < int(s["min_points"]):
        why.append(f"match band rests on {n_points} assessable frequencies < "
                   f"identify.min_points {int(s['min_points'])}")
    if why:
        return Verdict("poor", "; ".join(why), float(stable))
    return Verdict("ok", f"stable, hold-out fit {np.min(fit):.1f} % >= {float(s['fit_min']):g} "
                   f"%, match band on {n_points} assessable frequencies", 1.0)
