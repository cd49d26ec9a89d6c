"""Speed bins: bin edges, per-bin averages of frame spectra, and their coordinates.

Shared by the waterfalls (:mod:`gbpipe.harmonics.spectra`) and the removal metrics
(:mod:`gbpipe.harmonics.metrics`), so that both bin speeds the same way.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rpm_edges", "bin_average", "rpm_coords"]


def rpm_edges(rpm_frame: np.ndarray, rpm_bins: int | np.ndarray) -> np.ndarray:
    """Speed bin edges [rev/min].

    Parameters
    ----------
    rpm_frame : numpy.ndarray
        Speeds to be binned [rev/min] (NaN ignored).
    rpm_bins : int or array_like
        Number of equal bins between the lowest and highest speed (the top edge nudged up
        so the highest speed falls inside), or the edges themselves.

    Returns
    -------
    numpy.ndarray
        Increasing edges, one more than bins.
    """
    if isinstance(rpm_bins, int | np.integer) and not isinstance(rpm_bins, bool):
        if rpm_bins < 1:
            raise ValueError(f"rpm_bins must be >= 1 bins or an array of edges; got {rpm_bins}")
        ok = rpm_frame[np.isfinite(rpm_frame)]
        if ok.size == 0:
            raise ValueError("no frame has a defined speed: check rpm / pulse_times")
        lo, hi = float(ok.min()), float(ok.max())
        if hi - lo < 1e-9 * max(abs(hi), 1.0):
            lo, hi = lo - 0.5, hi + 0.5
        return np.linspace(lo, hi + 1e-9 * max(abs(hi), 1.0), int(rpm_bins) + 1)
    edges = np.asarray(rpm_bins, dtype=float)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("rpm_bins must be a bin count or a 1-D increasing array of >= 2 bin "
                         f"edges in rev/min; got {rpm_bins!r}")
    return edges


def bin_average(power: np.ndarray, rpm_frame: np.ndarray,
                edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of the rows of ``power`` (frames) whose speed falls in each bin.

    Returns
    -------
    mean : numpy.ndarray, shape (bins, power.shape[1])
        NaN in bins without a frame.
    counts : numpy.ndarray of int, shape (bins,)
        Frames averaged per bin.
    """
    b = np.digitize(rpm_frame, edges) - 1
    ok = np.isfinite(rpm_frame) & (b >= 0) & (b < edges.size - 1)
    nb = edges.size - 1
    counts = np.bincount(b[ok], minlength=nb)
    sums = np.zeros((nb, power.shape[1]))
    np.add.at(sums, b[ok], power[ok])
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts[:, None]
    mean[counts == 0] = np.nan
    return mean, counts


def rpm_coords(edges: np.ndarray) -> dict:
    """xarray coordinates ``rpm`` (bin centres), ``rpm_lower``, ``rpm_upper`` on dim ``rpm``."""
    centre = 0.5 * (edges[:-1] + edges[1:])
    return {
        "rpm": ("rpm", centre, {"units": "rev/min", "long_name": "shaft speed (bin centre)"}),
        "rpm_lower": ("rpm", edges[:-1], {"units": "rev/min",
                                          "long_name": "shaft speed bin lower edge"}),
        "rpm_upper": ("rpm", edges[1:], {"units": "rev/min",
                                         "long_name": "shaft speed bin upper edge"}),
    }
