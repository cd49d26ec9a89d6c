"""Metrics of a harmonic removal: what went, and what must stay.

For a signal before and after a removal (e.g. :func:`gbpipe.harmonics.residual`):

* :func:`family_attenuation` -- attenuation [dB] of each removed order family,
  from order-tracked amplitudes (exact-order projections, :func:`gbpipe.harmonics.order_amplitudes`)
  before vs after, overall and per rpm bin;
* :func:`mode_band_change` -- change [dB] of the power in a band around each structural
  mode (fixed frequency, Hz), overall and per rpm bin, with a flag where a removed family
  crosses the band (there the change measures the family, not the mode);
* :func:`removal_metrics` -- both, merged into one :class:`xarray.Dataset`.

The paper feared that averaging over short cycles could remove a resonance "by
mistake"; ``mode_change`` answers that: TSA leaves non-synchronous power at
``(1 - 1/N)`` (-0.46 dB at N = 10, 0 dB with ``unbiased=True``), so a change much below
that outside crossing bins means the resonance itself was eaten.

Attenuation is ``10 log10(P_before / P_after)`` with ``P`` the summed power
``|A_k|^2 / 2`` of the family's orders: positive = removed. Band change is
``10 log10(P_after / P_before)``: 0 = untouched, negative = lost. When ``after`` has
been removed down to the noise, the attenuation reads the line-to-noise ratio of the
order projection, which is the measurement limit, not the removal's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fractions import Fraction

import numpy as np
import xarray as xr

from gbpipe.harmonics.angle import AngleMap, revolution_speed
from gbpipe.harmonics.binning import rpm_coords, rpm_edges
from gbpipe.harmonics.checks import (
    as_count,
    as_order,
    as_positive,
    as_pulses,
    as_signal,
    check_within_record,
)
from gbpipe.harmonics.spectra import order_spectrum_vs_rpm, power_spectrum_vs_rpm
from gbpipe.harmonics.tacho import AngleMethod
from gbpipe.harmonics.tracking import order_amplitudes
from gbpipe.units import TWO_PI

__all__ = ["Families", "family_attenuation", "mode_band_change", "removal_metrics"]

#: Removed order families: name -> orders [HSS orders].
Families = Mapping[str, Sequence[float | Fraction]]


def _check_pair(before: np.ndarray, after: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    b = as_signal(before, "before")
    a = as_signal(after, "after")
    if a.shape != b.shape:
        raise ValueError(f"before and after must have the same length; got {b.size} and "
                         f"{a.size}")
    return b, a


def _check_families(families: Families) -> dict[str, np.ndarray]:
    if not isinstance(families, Mapping) or not families:
        raise TypeError("families must be a non-empty mapping name -> orders, e.g. "
                        "{'hss': [1, 2, 3], 'mesh2': family_orders(ratio, 20)}")
    out = {}
    for name, ords in families.items():
        arr = np.array([as_order(o, f"families[{name!r}]")
                        for o in np.atleast_1d(np.asarray(ords, dtype=object))], dtype=float)
        if arr.size == 0:
            raise ValueError(f"families[{name!r}] is empty: give at least one order")
        out[str(name)] = arr
    return out


def _bin_segments(theta_rev: np.ndarray, rpm_rev: np.ndarray,
                  edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle segments of consecutive revolutions in one rpm bin, and each segment's bin."""
    b = np.digitize(rpm_rev, edges) - 1
    b[(b < 0) | (b >= edges.size - 1)] = -1
    cut = np.flatnonzero(np.diff(b)) + 1
    starts = np.concatenate([[0], cut])
    stops = np.concatenate([cut, [b.size]])
    seg = np.column_stack([theta_rev[starts], theta_rev[stops - 1] + TWO_PI])
    return seg, b[starts]


def family_attenuation(
    before: np.ndarray,
    after: np.ndarray | Sequence[np.ndarray],
    fs: float,
    pulse_times: np.ndarray,
    families: Families,
    *,
    rpm_bins: int | np.ndarray = 12,
    band: float | None = 0.1,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: AngleMethod = "pchip",
) -> xr.Dataset | list[xr.Dataset]:
    """Attenuation of each order family, overall and per rpm bin.

    Two measures. *Line*: order-tracked amplitude at each exact order (projection), the
    classic order-tracking figure. *Band*: order-spectrum power within ``+-band`` orders
    of each order; it also sees what a block average leaves *next to* the orders --
    block-to-block changes of the estimate make sidebands spaced ``cycle_order / N``,
    which is where a plain cascade leaves the other family (-20 dB) and which the line
    measure misses. The band measure is limited by the broadband noise in the bands.

    Parameters
    ----------
    before, after : array_like, shape (n,)
        Signal before and after removal (same unit), sample ``i`` at ``t0 + i / fs``.
        ``after`` may be a list of several signals after removal: each is scored against
        ``before`` as in a call of its own (the same numbers), and ``before`` is tracked
        once for all of them.
    fs : float
        Sample rate [Hz].
    pulse_times : array_like
        HSS tachometer pulse times [s].
    families : mapping str -> sequence of float or Fraction
        Orders [HSS orders] of each removed family (e.g. from
        :func:`gbpipe.harmonics.family_orders`).
    rpm_bins : int or array_like
        Number of equal speed bins over the record, or bin edges [rev/min]. Each bin uses
        the complete revolutions whose mean speed falls in it; orders closer than about
        2 / (revolutions in the bin) leak into each other.
    band : float or None
        Half width of the bands of the band measure [orders]; None skips it. The order
        spectrum behind it has resolution ``band / 2.5`` (frames of ``2.5 / band`` revs).
    pulses_per_rev, t0, method
        As in :func:`gbpipe.harmonics.resample_to_angle`.

    Returns
    -------
    xarray.Dataset or list of xarray.Dataset
        ``attenuation`` (family) [dB], ``attenuation_vs_rpm`` (family, rpm) [dB] (line
        measure); ``attenuation_band``, ``attenuation_band_vs_rpm`` (band measure);
        ``power_before``/``power_after`` (family) [units^2 of the signal, relative];
        coordinates ``family`` and ``rpm`` [rev/min] (bin centres and edges). One per
        signal when ``after`` is a list.
    """
    several = isinstance(after, list)
    pairs = [_check_pair(before, a) for a in (after if several else [after])]
    if not pairs:
        raise ValueError("after is an empty list: give at least one signal after removal")
    b = pairs[0][0]
    fam = _check_families(families)
    fs = as_positive(fs, "fs", "Hz")
    band = None if band is None else as_positive(band, "band", "orders")
    p = as_pulses(pulse_times)
    ppr = as_count(pulses_per_rev, "pulses_per_rev")
    check_within_record(p, float(t0), fs, b.size)
    amap = AngleMap.build(b.size, fs, p, ppr, method, float(t0))
    theta_rev, rpm_rev = revolution_speed(amap)
    edges = rpm_edges(rpm_rev, rpm_bins)
    seg, seg_bin = _bin_segments(theta_rev, rpm_rev, edges)
    all_orders = np.concatenate(list(fam.values()))
    whole = np.array([[0.0, theta_rev[-1] + TWO_PI]])
    segments = np.vstack([whole, seg])
    # every signal in one call: one angle grid and one window per segment for them all
    # (each column is resampled and projected on its own: the numbers of a call of its own)
    amp = order_amplitudes(np.column_stack([b, *(a for _, a in pairs)]), fs, p, all_orders,
                           pulses_per_rev=ppr, t0=t0, method=method, segments=segments)
    pb = np.abs(amp[:, 0]) ** 2 / 2
    # Per-bin power: segments of a bin weighted by their length (revolutions).
    length = np.diff(segments[1:], axis=1)[:, 0]
    nb = edges.size - 1
    names = list(fam)
    coords = rpm_coords(edges)
    coords["family"] = ("family", names, {"units": "1", "long_name": "removed order family"})
    out = []
    for j, (_, a) in enumerate(pairs, 1):
        pa = np.abs(amp[:, j]) ** 2 / 2
        att = np.full(len(names), np.nan)
        att_rpm = np.full((len(names), nb), np.nan)
        pw_b = np.zeros(len(names))
        pw_a = np.zeros(len(names))
        start = 0
        for f, name in enumerate(names):  # loop over a few families
            cols = slice(start, start + fam[name].size)
            start += fam[name].size
            pw_b[f] = np.nansum(pb[0, cols])
            pw_a[f] = np.nansum(pa[0, cols])
            att[f] = 10 * np.log10(pw_b[f] / pw_a[f])
            sb = np.nansum(pb[1:, cols], axis=1)
            sa = np.nansum(pa[1:, cols], axis=1)
            ok = (seg_bin >= 0) & np.isfinite(pb[1:, cols.start])
            num = np.bincount(seg_bin[ok], weights=(sb * length)[ok], minlength=nb)
            den = np.bincount(seg_bin[ok], weights=(sa * length)[ok], minlength=nb)
            with np.errstate(divide="ignore", invalid="ignore"):
                att_rpm[f] = np.where((num > 0) & (den > 0), 10 * np.log10(num / den),
                                      np.nan)
        extra = {}
        if band is not None:
            att_b, att_b_rpm = _band_attenuation(b, a, fs, p, fam, edges, band, ppr, t0,
                                                 method)
            extra = {
                "attenuation_band": ("family", att_b, {"units": "dB", "long_name":
                                     "attenuation of order-spectrum power within the "
                                     "family's order bands, whole record",
                                     "band_orders": band}),
                "attenuation_band_vs_rpm": (("family", "rpm"), att_b_rpm, {
                    "units": "dB", "long_name": "attenuation of order-spectrum power within "
                    "the family's order bands per rpm bin", "band_orders": band}),
            }
        out.append(xr.Dataset(
            {
                **extra,
                "attenuation": ("family", att, {
                    "units": "dB", "long_name": "attenuation of the family's order-tracked "
                    "power, whole record"}),
                "attenuation_vs_rpm": (("family", "rpm"), att_rpm, {
                    "units": "dB", "long_name": "attenuation of the family's order-tracked "
                    "power per rpm bin"}),
                "power_before": ("family", pw_b, {"units": "1", "long_name":
                                 "family power before removal (signal units squared)"}),
                "power_after": ("family", pw_a, {"units": "1", "long_name":
                                "family power after removal (signal units squared)"}),
            },
            coords=coords,
        ))
    return out if several else out[0]


def _band_attenuation(b, a, fs, p, fam, edges, band, ppr, t0, method):
    max_order = max(float(o.max()) for o in fam.values()) + 2 * band + 1.0
    kw = dict(resolution=band / 2.5, max_order=max_order, rpm_bins=edges,
              pulses_per_rev=ppr, t0=t0, method=method)
    sb = order_spectrum_vs_rpm(b, fs, p, **kw)
    sa = order_spectrum_vs_rpm(a, fs, p, **kw)
    o = sb.order.values
    n = sb.n_averages.values
    ok = n > 0
    att = np.full(len(fam), np.nan)
    att_rpm = np.full((len(fam), n.size), np.nan)
    for f, ords in enumerate(fam.values()):
        sel = (np.abs(o[:, None] - ords[None, :]) <= band).any(axis=1)  # union of bands
        pb = np.where(ok, sb.power.values[:, sel].sum(axis=1), 0.0)
        pa = np.where(ok, sa.power.values[:, sel].sum(axis=1), 0.0)
        att[f] = 10 * np.log10(np.sum(pb * n) / np.sum(pa * n))
        with np.errstate(divide="ignore", invalid="ignore"):
            att_rpm[f] = np.where(ok, 10 * np.log10(pb / pa), np.nan)
    return att, att_rpm


def mode_band_change(
    before: np.ndarray,
    after: np.ndarray,
    fs: float,
    modes: Sequence[float],
    *,
    pulse_times: np.ndarray | None = None,
    rpm: np.ndarray | None = None,
    families: Families | None = None,
    half_width: float | Sequence[float] = 4.0,
    resolution: float = 0.5,
    rpm_bins: int | np.ndarray = 12,
    window: str | tuple = "hann",
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: AngleMethod = "pchip",
) -> xr.Dataset:
    """Change of the power in a band around each structural mode.

    Parameters
    ----------
    before, after : array_like, shape (n,)
        Signal before and after removal.
    fs : float
        Sample rate [Hz].
    modes : sequence of float
        Mode frequencies [Hz].
    pulse_times, rpm : array_like, optional
        Speed source for the rpm bins (exactly one): HSS pulse times [s], or speed per
        sample [rev/min].
    families : mapping str -> orders, optional
        Removed families [HSS orders]; a bin is flagged where any of their orders passes
        through the band (at any speed of the bin).
    half_width : float or sequence of float
        Half width of each band [Hz] (one for all modes, or one per mode).
    resolution : float
        Frequency resolution of the underlying waterfall [Hz].
    rpm_bins, window, pulses_per_rev, t0, method
        As in :func:`gbpipe.harmonics.power_spectrum_vs_rpm`.

    Returns
    -------
    xarray.Dataset
        ``mode_change`` (mode) [dB] over the bins without a crossing;
        ``mode_change_all`` (mode) [dB] over all bins; ``mode_change_vs_rpm`` (mode, rpm)
        [dB]; ``crossing`` (family, mode, rpm) [0/1]. Coordinates ``mode_frequency``
        [Hz] on ``mode``, ``rpm`` [rev/min], ``family``.
    """
    b, a = _check_pair(before, after)
    fs = as_positive(fs, "fs", "Hz")
    fm = np.array([as_positive(m, "modes", "Hz") for m in np.atleast_1d(modes)])
    hw = np.broadcast_to(np.asarray(half_width, dtype=float), fm.shape).copy()
    if np.any(hw <= 0):
        raise ValueError(f"half_width must be > 0 Hz; got {half_width}")
    fam = _check_families(families) if families else {}
    kw = dict(rpm=rpm, pulse_times=pulse_times, resolution=resolution, window=window,
              rpm_bins=rpm_bins, pulses_per_rev=pulses_per_rev, t0=t0, method=method)
    wb = power_spectrum_vs_rpm(b, fs, **kw)
    # Same edges for "after", so that both are binned identically.
    kw["rpm_bins"] = np.concatenate([wb.rpm_lower.values, wb.rpm_upper.values[-1:]])
    wa = power_spectrum_vs_rpm(a, fs, **kw)
    f = wb.frequency.values
    df = f[1]
    lo, hi = wb.rpm_lower.values, wb.rpm_upper.values
    n_avg = wb.n_averages.values
    nm, nr = fm.size, lo.size
    change_rpm = np.full((nm, nr), np.nan)
    cross = np.zeros((max(len(fam), 1), nm, nr), dtype=np.int8)
    change = np.full(nm, np.nan)
    change_all = np.full(nm, np.nan)
    for m in range(nm):  # loop over a few modes
        band = np.abs(f - fm[m]) <= hw[m]
        pb = wb.power.values[:, band].sum(axis=1)
        pa = wa.power.values[:, band].sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            change_rpm[m] = 10 * np.log10(pa / pb)
        for k, ords in enumerate(fam.values()):
            # Frequencies swept by each order over the bin, widened by one bin of leakage.
            f_lo = np.outer(lo, ords) / 60.0
            f_hi = np.outer(hi, ords) / 60.0
            hit = (f_hi >= fm[m] - hw[m] - 2 * df) & (f_lo <= fm[m] + hw[m] + 2 * df)
            cross[k, m] = hit.any(axis=1)
        free = (cross[:, m].sum(axis=0) == 0) & (n_avg > 0)
        ok = n_avg > 0
        if free.any():
            change[m] = 10 * np.log10(np.sum((pa * n_avg)[free]) / np.sum((pb * n_avg)[free]))
        change_all[m] = 10 * np.log10(np.sum((pa * n_avg)[ok]) / np.sum((pb * n_avg)[ok]))
    coords = rpm_coords(np.concatenate([lo, hi[-1:]]))
    coords["mode_frequency"] = ("mode", fm, {"units": "Hz", "long_name": "mode frequency"})
    coords["band_half_width"] = ("mode", hw, {"units": "Hz",
                                              "long_name": "half width of the mode band"})
    coords["family"] = ("family", list(fam) or ["none"],
                        {"units": "1", "long_name": "removed order family"})
    return xr.Dataset(
        {
            "mode_change": ("mode", change, {"units": "dB", "long_name":
                            "change of mode-band power, rpm bins without a family crossing"}),
            "mode_change_all": ("mode", change_all, {"units": "dB", "long_name":
                                "change of mode-band power, all rpm bins"}),
            "mode_change_vs_rpm": (("mode", "rpm"), change_rpm, {"units": "dB", "long_name":
                                   "change of mode-band power per rpm bin"}),
            "crossing": (("family", "mode", "rpm"), cross, {"units": "1", "long_name":
                         "1 where an order of the removed family crosses the mode band"}),
        },
        coords=coords,
    )


def removal_metrics(
    before: np.ndarray, after: np.ndarray, fs: float, pulse_times: np.ndarray,
    families: Families, modes: Sequence[float], *, rpm_bins: int | np.ndarray = 12,
    band: float | None = 0.1, half_width: float | Sequence[float] = 4.0,
    resolution: float = 0.5, pulses_per_rev: int = 1, t0: float = 0.0,
    method: AngleMethod = "pchip",
) -> xr.Dataset:
    """:func:`family_attenuation` and :func:`mode_band_change` on the same rpm bins.

    Parameters
    ----------
    before, after, fs, pulse_times, families, band, pulses_per_rev, t0, method
        As in :func:`family_attenuation`.
    modes, half_width, resolution
        As in :func:`mode_band_change`.
    rpm_bins : int or array_like
        Bin count or edges [rev/min]; a count spans the revolution speeds of the record.

    Returns
    -------
    xarray.Dataset
        Variables of both functions; ``crossing`` flags the (family, mode, rpm bin) where
        a removed family passes through a mode band.
    """
    att = family_attenuation(before, after, fs, pulse_times, families, rpm_bins=rpm_bins,
                             band=band, pulses_per_rev=pulses_per_rev, t0=t0, method=method)
    edges = np.concatenate([att.rpm_lower.values, att.rpm_upper.values[-1:]])
    band = mode_band_change(before, after, fs, modes, pulse_times=pulse_times,
                            families=families, half_width=half_width, resolution=resolution,
                            rpm_bins=edges, pulses_per_rev=pulses_per_rev, t0=t0,
                            method=method)
    return xr.merge([att, band], compat="override", join="override")
