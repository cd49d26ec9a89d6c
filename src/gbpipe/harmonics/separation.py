"""The exact separation metric of a harmonic removal, in simulation.

On a measured record the residual of a removal mixes what it left of the harmonics with
what it damaged of the broadband response, and neither can be read cleanly. In
simulation both are known: the record is the sum of a *harmonic* part (the response to
the angle-locked excitation) and a *random-only* part (the same simulation with every
excitation amplitude at zero and the same seeds), so ``residual - random_only`` is
exactly the removal's error. Per rpm bin (the bins of
:func:`gbpipe.harmonics.family_attenuation`, :mod:`gbpipe.harmonics.binning`):

* ``attenuation_db`` (family, rpm): ``10 log10(P_family(harmonic) /
  P_family(residual - random_only))``, order-tracked power at the family's orders: how far
  the family went, with no broadband floor in the way;
* ``distortion_db`` (band, rpm): ``10 log10(P_band(residual - random_only) /
  P_band(random_only))``, the error power in a frequency band relative to the random
  part there, for a band around every structural mode and for the rest of the spectrum
  (``elsewhere``): very negative = untouched;
* ``change_db`` (band, rpm): ``10 log10(P_band(residual) / P_band(random_only))``, the
  level error a band-power reading would show (the issue's "within 1 dB");
* ``leftover_db`` (family, rpm), when the method's output on the harmonic part alone is
  given: the family's attenuation free of the random part's own components at the orders.

Everything is computed over the pulse span only (the samples every method processes).

``crossing`` flags the (family, mode band, rpm bin) where an order of the family passes
through the band: there the error also holds the family's leftovers (never flagged for
``elsewhere``, which every family crosses).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from gbpipe.harmonics.checks import as_positive, as_signal
from gbpipe.harmonics.metrics import Families, family_attenuation
from gbpipe.harmonics.removal_inputs import family_orders_checked, record_angle
from gbpipe.harmonics.spectra import power_spectrum_vs_rpm
from gbpipe.harmonics.tacho import AngleMethod

__all__ = ["frequency_bands", "separation_metrics", "band_power_vs_rpm"]


def frequency_bands(modes: Sequence[float], half_width: float, f_min: float,
                    f_max: float) -> tuple[list[str], np.ndarray]:
    """Bands around each mode, and ``elsewhere``: the rest of ``[f_min, f_max]``.

    Returns
    -------
    names : list of str
        ``"mode_<f>Hz"`` per mode, then ``"elsewhere"``.
    limits : numpy.ndarray, shape (bands, 2)
        Lower and upper limit of each band [Hz] (``elsewhere``: ``f_min``, ``f_max``, minus
        the mode bands).
    """
    fm = np.array([as_positive(m, "modes", "Hz") for m in modes], dtype=float)
    names = [f"mode_{f:.1f}Hz" for f in fm] + ["elsewhere"]
    limits = np.vstack([np.column_stack([fm - half_width, fm + half_width]),
                        [[f_min, f_max]]])
    return names, limits


def _band_power(power: np.ndarray, freq: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """Power (rpm, bands) summed over each band; ``elsewhere`` (last) excludes the others."""
    in_mode = [(freq >= lo) & (freq <= hi) for lo, hi in limits[:-1]]
    rest = (freq >= limits[-1, 0]) & (freq <= limits[-1, 1])
    for sel in in_mode:
        rest &= ~sel
    return np.stack([power[:, sel].sum(axis=1) for sel in [*in_mode, rest]], axis=1)


def separation_metrics(
    residual: np.ndarray,
    random_only: np.ndarray,
    harmonic: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    families: Families,
    modes: Sequence[float],
    *,
    rpm_bins: int | np.ndarray = 12,
    half_width: float = 4.0,
    resolution: float = 0.5,
    f_min: float = 10.0,
    f_max: float | None = None,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: AngleMethod = "pchip",
    harmonic_residual: np.ndarray | None = None,
) -> xr.Dataset:
    """Attenuation of each family and broadband distortion per band, per rpm bin.

    Parameters
    ----------
    residual : array_like, shape (n,)
        The removal's output (unit of the record).
    random_only : array_like, shape (n,)
        The record without the angle-locked excitation (same seeds).
    harmonic : array_like, shape (n,)
        The angle-locked part: record minus ``random_only``.
    fs : float
        Sample rate [Hz].
    pulse_times : array_like
        HSS tachometer pulse times of the record [s].
    families : mapping str -> sequence of float or Fraction
        Orders [HSS orders] of the removed families.
    modes : sequence of float
        Structural mode frequencies [Hz]; a band of ``+-half_width`` around each.
    rpm_bins : int or array_like
        Bin count or edges [rev/min] (:func:`gbpipe.harmonics.family_attenuation`).
    half_width : float
        Half width of the mode bands [Hz].
    resolution : float
        Resolution of the waterfalls behind the band powers [Hz].
    f_min, f_max : float
        Limits of the ``elsewhere`` band [Hz]; ``f_max`` default ``fs / 2``.
    harmonic_residual : array_like, optional
        The same method run on ``harmonic`` alone; adds ``leftover_db``. For a linear
        method (TSA, VKF, regression) it is exactly the harmonic part of ``residual``, so
        ``leftover_db`` is the family's attenuation free of the random part's own
        components at the orders (which any removal takes with the harmonics and which
        bound ``attenuation_db`` by the line-to-random ratio).
    pulses_per_rev, t0, method
        As in :func:`gbpipe.harmonics.resample_to_angle`.

    Returns
    -------
    xarray.Dataset
        ``attenuation_db`` (family, rpm), ``leftover_db`` (family, rpm, with
        ``harmonic_residual``), ``distortion_db`` and ``change_db`` (band, rpm) [dB],
        ``crossing`` (family, band, rpm) [1], all over the pulse span; coordinates ``rpm``,
        ``rpm_lower``, ``rpm_upper`` [rev/min], ``family``, ``band``, ``band_lower``,
        ``band_upper`` [Hz].

    Raises
    ------
    DataError
        A signal with NaN/inf or of another length.
    """
    sigs = {"residual": residual, "random_only": random_only, "harmonic": harmonic}
    if harmonic_residual is not None:
        sigs["harmonic_residual"] = harmonic_residual
    sigs = {k: as_signal(v, k) for k, v in sigs.items()}
    if len({v.size for v in sigs.values()}) > 1:
        raise ValueError(f"the signals must have one length; got "
                         f"{ {k: v.size for k, v in sigs.items()} }")
    # Only the pulse span: outside it no method has an angle and every one returns the
    # record unchanged, which would read as a failure of the removal in the end bins.
    span = record_angle(sigs["residual"], fs, pulse_times, pulses_per_rev, t0, method).span
    fs = float(fs)
    t0 = float(t0) + span.start / fs
    p = np.asarray(pulse_times, dtype=float)
    pulse_times = p[(p >= t0) & (p <= t0 + (span.stop - span.start - 1) / fs)]
    r, n, h = (sigs[k][span] for k in ("residual", "random_only", "harmonic"))
    half_width = as_positive(half_width, "half_width", "Hz")
    f_max = 0.5 * fs if f_max is None else as_positive(f_max, "f_max", "Hz")
    fam = family_orders_checked(families)
    err = r - n
    opts = dict(rpm_bins=rpm_bins, band=None, pulses_per_rev=pulses_per_rev, t0=t0,
                method=method)
    # the harmonic part tracked once for the residual's error and the harmonic residual
    scored = [err] if harmonic_residual is None else [err, sigs["harmonic_residual"][span]]
    with np.errstate(divide="ignore"):  # a perfect removal: +inf dB, not an error
        att, *left = family_attenuation(h, scored, fs, pulse_times, fam, **opts)
    extra = {}
    if left:
        extra["leftover_db"] = (("family", "rpm"), left[0].attenuation_vs_rpm.values, {
            "units": "dB", "long_name": "family attenuation by the method run on the known "
                                        "harmonic part alone"})
    edges = np.concatenate([att.rpm_lower.values, att.rpm_upper.values[-1:]])
    names, limits = frequency_bands(modes, half_width, f_min, f_max)
    kw = dict(pulse_times=pulse_times, resolution=resolution, rpm_bins=edges,
              max_frequency=f_max, pulses_per_rev=pulses_per_rev, t0=t0, method=method)
    band = {}
    for key, sig in (("random", n), ("error", err), ("residual", r)):
        wf = power_spectrum_vs_rpm(sig, fs, **kw)
        band[key] = _band_power(wf.power.values, wf.frequency.values, limits)
    with np.errstate(divide="ignore", invalid="ignore"):
        distortion = 10 * np.log10(band["error"] / band["random"]).T
        change = 10 * np.log10(band["residual"] / band["random"]).T
    lo, hi = edges[:-1] / 60.0, edges[1:] / 60.0  # shaft rate range of each bin [rev/s]
    cross = np.zeros((len(fam), len(names), lo.size), dtype=np.int8)
    for k, ords in enumerate(fam.values()):  # an order o sweeps o*lo .. o*hi Hz in a bin
        for b, (f_lo, f_hi) in enumerate(limits[:-1]):
            cross[k, b] = ((ords[None, :] * hi[:, None] >= f_lo)
                           & (ords[None, :] * lo[:, None] <= f_hi)).any(axis=1)
    coords = {k: v for k, v in att.coords.items() if k in ("rpm", "rpm_lower", "rpm_upper")}
    coords.update(
        family=("family", list(fam), {"units": "1", "long_name": "removed order family"}),
        band=("band", names, {"units": "1", "long_name": "frequency band"}),
        band_lower=("band", limits[:, 0], {"units": "Hz", "long_name": "band lower limit"}),
        band_upper=("band", limits[:, 1], {"units": "Hz", "long_name": "band upper limit"}),
    )
    return xr.Dataset(
        {
            **extra,
            "attenuation_db": (("family", "rpm"), att.attenuation_vs_rpm.values, {
                "units": "dB", "long_name": "family attenuation on the known harmonic part"}),
            "distortion_db": (("band", "rpm"), distortion, {
                "units": "dB", "long_name": "power of residual minus random-only, relative "
                                            "to random-only, in the band"}),
            "change_db": (("band", "rpm"), change, {
                "units": "dB", "long_name": "power of the residual relative to random-only, "
                                            "in the band"}),
            "crossing": (("family", "band", "rpm"), cross, {
                "units": "1", "long_name": "1 where an order of the family crosses the band"}),
        },
        coords=coords,
    )


def band_power_vs_rpm(signals: Sequence[np.ndarray], fs: float, pulse_times: np.ndarray,
                      limits: tuple[float, float], rpm_edges: np.ndarray, *,
                      resolution: float = 0.5, pulses_per_rev: int = 1) -> np.ndarray:
    """Power of each signal within one frequency band, per rpm bin.

    Parameters
    ----------
    signals : sequence of array_like, shape (n,)
        Signals of one record (one unit).
    fs : float
        Sample rate [Hz].
    pulse_times : array_like
        HSS tachometer pulse times [s].
    limits : tuple of float
        Lower and upper limit of the band [Hz].
    rpm_edges : array_like
        Bin edges [rev/min].
    resolution : float
        Resolution of the waterfall behind the band power [Hz].
    pulses_per_rev : int
        Tachometer pulses per HSS revolution.

    Returns
    -------
    numpy.ndarray, shape (signals, bins)
        Band power [signal unit squared], NaN in a bin no frame falls in.
    """
    kw = dict(pulse_times=pulse_times, resolution=resolution, rpm_bins=rpm_edges,
              max_frequency=min(2.0 * limits[1], 0.5 * fs), pulses_per_rev=pulses_per_rev)
    out = []
    for x in signals:
        wf = power_spectrum_vs_rpm(as_signal(x, "signal"), fs, **kw)
        p = _band_power(wf.power.values, wf.frequency.values,
                        np.array([limits, [limits[0], limits[1]]]))[:, 0]
        out.append(np.where(wf.n_averages.values > 0, p, np.nan))
    return np.array(out)
