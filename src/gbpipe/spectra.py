"""Spectra of rotating-machine signals vs shaft speed (waterfalls).

* :func:`power_spectrum_vs_rpm` -- power spectrum vs frequency [Hz] and rpm (paper Fig 11);
* :func:`order_spectrum_vs_rpm` -- order spectrum vs order [-] and rpm (Figs 13, 15, 17).

Both cut the record into windowed frames (in time, or in shaft angle after order
tracking), give every frame its mean speed, and average the frame periodograms within
each rpm bin. They return an :class:`xarray.Dataset` with coordinates ``rpm`` [rev/min]
(bin centres, with ``rpm_lower``/``rpm_upper`` edges) and ``frequency`` [Hz] or
``order`` [-], a ``power`` variable and the number of frames averaged per bin
``n_averages``; every variable and coordinate carries ``units`` and ``long_name``.

Scaling. ``scaling="spectrum"`` (default) is a power spectrum in signal units squared
(e.g. "N2 m2" for a torque in "N m"): a sinusoid of amplitude A centred on a bin shows
A**2 / 2, i.e. its mean square -- what the paper's Fig 11 plots in dB and what Testlab
calls an autopower "RMS" spectrum. Broadband noise level then depends on the resolution.
``scaling="density"`` gives a PSD in units squared per Hz (sinusoids then depend on the
resolution). Order spectra are power spectra only (a density per order is rarely wanted).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import xarray as xr
from numpy.lib.stride_tricks import sliding_window_view

from gbpipe import orders as _orders

__all__ = ["power_spectrum_vs_rpm", "order_spectrum_vs_rpm", "squared_units"]

RPM_PER_RAD_S = 60.0 / (2.0 * np.pi)


def squared_units(units: str) -> str:
    """UDUNITS string of ``units`` squared: "N m" -> "N2 m2", "rad s-1" -> "rad2 s-2".

    Parameters
    ----------
    units : str
        Unit string; space-separated factors with optional integer exponents are squared
        factor by factor, anything else becomes ``"(units)^2"``.

    Returns
    -------
    str
    """
    u = units.strip()
    if u in ("", "1", "-"):
        return "1"
    parts = u.split()
    out = []
    for part in parts:
        name = part.rstrip("-0123456789")
        exp_txt = part[len(name):]
        if not name.isalpha() or (exp_txt and not exp_txt.lstrip("-").isdigit()):
            return f"({u})^2"
        exp = int(exp_txt) if exp_txt else 1
        out.append(f"{name}{2 * exp}")
    return " ".join(out)


def _check_overlap(overlap: float) -> float:
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be in [0, 1) (fraction of a frame); got {overlap}")
    return float(overlap)


def _rpm_edges(rpm_frame: np.ndarray, rpm_bins: int | np.ndarray) -> np.ndarray:
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


def _bin_average(power: np.ndarray, rpm_frame: np.ndarray,
                 edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def _rpm_coords(edges: np.ndarray) -> dict:
    centre = 0.5 * (edges[:-1] + edges[1:])
    return {
        "rpm": ("rpm", centre, {"units": "rev/min", "long_name": "shaft speed (bin centre)"}),
        "rpm_lower": ("rpm", edges[:-1], {"units": "rev/min",
                                          "long_name": "shaft speed bin lower edge"}),
        "rpm_upper": ("rpm", edges[1:], {"units": "rev/min",
                                         "long_name": "shaft speed bin upper edge"}),
    }


def _one_sided(spec: np.ndarray, n: int) -> np.ndarray:
    # Double every bin but DC (and Nyquist for even n): one-sided power.
    spec[..., 1:] *= 2.0
    if n % 2 == 0:
        spec[..., -1] /= 2.0
    return spec


def power_spectrum_vs_rpm(
    x: np.ndarray,
    fs: float,
    rpm: np.ndarray | None = None,
    pulse_times: np.ndarray | None = None,
    *,
    resolution: float = 0.5,
    window: str | tuple = "hann",
    overlap: float = 0.5,
    rpm_bins: int | np.ndarray = 36,
    scaling: Literal["spectrum", "density"] = "spectrum",
    max_frequency: float | None = None,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: _orders.AngleMethod = "pchip",
    units: str = "1",
    long_name: str = "signal",
) -> xr.Dataset:
    """Power spectrum vs frequency and shaft speed (waterfall).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal in ``units``, sample ``i`` at ``t0 + i / fs``.
    fs : float
        Sample rate [Hz].
    rpm : array_like, shape (n,), optional
        Shaft speed at every sample [rev/min]. Give this or ``pulse_times``.
    pulse_times : array_like, optional
        Tachometer pulse times [s]; each frame's speed is then its exact mean speed
        (angle advance / duration). Frames outside the pulse span are dropped.
    resolution : float
        Frequency resolution [Hz] (frame length ``round(fs / resolution)`` samples).
    window : str or tuple
        :func:`scipy.signal.get_window` spec.
    overlap : float
        Frame overlap fraction in [0, 1).
    rpm_bins : int or array_like
        Number of equal bins between the lowest and highest frame speed, or bin edges
        [rev/min]. A frame goes to the bin holding its mean speed.
    scaling : {"spectrum", "density"}
        Power spectrum [units^2] or power spectral density [units^2/Hz] (module notes).
    max_frequency : float, optional
        Highest frequency kept [Hz]; default ``fs / 2``.
    pulses_per_rev, method : int, str
        Passed to :func:`gbpipe.orders.shaft_angle` when ``pulse_times`` is used.
    t0 : float
        Time of the first sample [s].
    units, long_name : str
        Unit and name of ``x``.

    Returns
    -------
    xarray.Dataset
        ``power`` (rpm, frequency) and ``n_averages`` (rpm); coordinates ``rpm``,
        ``rpm_lower``, ``rpm_upper`` [rev/min] and ``frequency`` [Hz]. Bins without a
        frame are NaN.

    Raises
    ------
    ValueError
        Neither or both of ``rpm`` and ``pulse_times``; frame longer than the record; bad
        arguments.
    """
    x = _orders._as_signal(x)
    fs = _orders._as_positive(fs, "fs", "Hz")
    resolution = _orders._as_positive(resolution, "resolution", "Hz")
    overlap = _check_overlap(overlap)
    if scaling not in ("spectrum", "density"):
        raise ValueError(f"scaling must be 'spectrum' or 'density'; got {scaling!r}")
    if (rpm is None) == (pulse_times is None):
        raise ValueError("give exactly one of rpm (rev/min per sample) and pulse_times (s)")
    nper = int(round(fs / resolution))
    if nper > x.size or nper < 4:
        raise ValueError(
            f"resolution={resolution} Hz needs frames of {nper} samples but the record has "
            f"{x.size}: choose resolution between {fs / x.size:.3g} and {fs / 4:.3g} Hz"
        )
    hop = max(1, int(round(nper * (1.0 - overlap))))
    starts = np.arange(0, x.size - nper + 1, hop)
    if rpm is not None:
        r = _orders._as_signal(rpm, "rpm")
        if r.size != x.size:
            raise ValueError(f"rpm must have one value per sample of x ({x.size}); got {r.size}")
        cs = np.concatenate([[0.0], np.cumsum(r)])
        rpm_frame = (cs[starts + nper] - cs[starts]) / nper
    else:
        p = _orders._as_pulses(pulse_times)
        _orders._check_within_record(p, float(t0), fs, x.size)
        ta = t0 + starts / fs
        tb = t0 + (starts + nper - 1) / fs
        th = _orders.shaft_angle(np.concatenate([ta, tb]), p, pulses_per_rev=pulses_per_rev,
                                 method=method)
        rpm_frame = (th[starts.size:] - th[:starts.size]) / (tb - ta) * RPM_PER_RAD_S
    edges = _rpm_edges(rpm_frame, rpm_bins)
    w = _orders._window(window, nper)
    frames = sliding_window_view(x, nper)[starts]
    spec = np.abs(np.fft.rfft(frames * w, axis=1)) ** 2
    if scaling == "spectrum":
        spec /= w.sum() ** 2
        unit = squared_units(units)
        what = "power spectrum"
    else:
        spec /= fs * np.sum(w**2)
        unit = f"{squared_units(units)} Hz-1" if squared_units(units) != "1" else "Hz-1"
        what = "power spectral density"
    spec = _one_sided(spec, nper)
    freq = np.fft.rfftfreq(nper, 1.0 / fs)
    if max_frequency is not None:
        keep = freq <= max_frequency
        freq, spec = freq[keep], spec[:, keep]
    mean, counts = _bin_average(spec, rpm_frame, edges)
    coords = _rpm_coords(edges)
    coords["frequency"] = ("frequency", freq, {"units": "Hz", "long_name": "frequency"})
    return xr.Dataset(
        {
            "power": (("rpm", "frequency"), mean,
                      {"units": unit, "long_name": f"{what} of {long_name}",
                       "window": str(window), "resolution_hz": float(fs / nper),
                       "overlap": overlap, "scaling": scaling}),
            "n_averages": ("rpm", counts, {"units": "1",
                                           "long_name": "number of frames averaged"}),
        },
        coords=coords,
    )


@dataclass
class _OrderFrames:
    power: np.ndarray  # (frames, orders), units^2
    order: np.ndarray
    rpm: np.ndarray  # mean speed of each frame [rev/min]


def _order_frames(x, fs, pulse_times, *, resolution, max_order, window, overlap,
                  pulses_per_rev, t0, method) -> _OrderFrames:
    x, fs, p, ppr, amap = _orders._prepare(x, fs, pulse_times, pulses_per_rev, method, t0)
    resolution = _orders._as_positive(resolution, "resolution", "orders")
    max_order = _orders._as_positive(max_order, "max_order", "orders")
    overlap = _check_overlap(overlap)
    from scipy.fft import next_fast_len

    spr = int(next_fast_len(int(np.ceil(2.5 * max_order))))  # max order at 0.4 x spr
    theta, xa = _orders._to_angle(x, amap, spr)
    spr = int(round(2 * np.pi / theta[1]))
    nper = int(round(spr / resolution))
    if nper > xa.size:
        raise ValueError(
            f"resolution={resolution} orders needs frames of {1 / resolution:.3g} revolutions "
            f"but the pulses span {theta[-1] / (2 * np.pi):.3g}: choose a coarser resolution"
        )
    hop = max(1, int(round(nper * (1.0 - overlap))))
    starts = np.arange(0, xa.size - nper + 1, hop)
    w = _orders._window(window, nper)
    frames = sliding_window_view(xa, nper)[starts]
    spec = _one_sided(np.abs(np.fft.rfft(frames * w, axis=1)) ** 2 / w.sum() ** 2, nper)
    # Mean speed of a frame: its angle span over its duration; times of the frame ends by
    # inverse interpolation of the sampled angle (a handful of points).
    t_samples = amap.t0 + (amap.j_lo + np.arange(amap.theta.size)) / amap.fs
    ta = np.interp(theta[starts], amap.theta, t_samples)
    tb = np.interp(theta[starts + nper - 1], amap.theta, t_samples)
    rpm_frame = (theta[starts + nper - 1] - theta[starts]) / (tb - ta) * RPM_PER_RAD_S
    return _OrderFrames(spec, np.fft.rfftfreq(nper, 1.0 / spr), rpm_frame)


def order_spectrum_vs_rpm(
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    *,
    resolution: float = 0.1,
    max_order: float = 40.0,
    window: str | tuple = "hann",
    overlap: float = 0.5,
    rpm_bins: int | np.ndarray = 36,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: _orders.AngleMethod = "pchip",
    units: str = "1",
    long_name: str = "signal",
) -> xr.Dataset:
    """Order power spectrum vs order and shaft speed (order waterfall).

    The record is resampled at constant angle of the tachometer shaft without aliasing
    (:func:`gbpipe.orders.resample_to_angle`, low-passed to about ``1.25 * max_order``),
    cut into frames of ``1 / resolution`` revolutions, windowed; frame periodograms are
    averaged per rpm bin. A component ``A cos(m theta)`` on an order bin shows ``A**2/2``.

    Parameters
    ----------
    x, fs, pulse_times, pulses_per_rev, t0, method
        As in :func:`gbpipe.orders.resample_to_angle`.
    resolution : float
        Order resolution [-]; each frame spans ``1 / resolution`` revolutions.
    max_order : float
        Highest order in the output [-].
    window, overlap, rpm_bins, units, long_name
        As in :func:`power_spectrum_vs_rpm`.

    Returns
    -------
    xarray.Dataset
        ``power`` (rpm, order) [units^2] and ``n_averages`` (rpm); coordinates ``rpm``,
        ``rpm_lower``, ``rpm_upper`` [rev/min] and ``order`` [-].
    """
    fr = _order_frames(x, fs, pulse_times, resolution=resolution, max_order=max_order,
                       window=window, overlap=overlap, pulses_per_rev=pulses_per_rev, t0=t0,
                       method=method)
    keep = fr.order <= max_order
    edges = _rpm_edges(fr.rpm, rpm_bins)
    mean, counts = _bin_average(fr.power[:, keep], fr.rpm, edges)
    coords = _rpm_coords(edges)
    coords["order"] = ("order", fr.order[keep],
                       {"units": "1", "long_name": "order of the tachometer shaft"})
    return xr.Dataset(
        {
            "power": (("rpm", "order"), mean,
                      {"units": squared_units(units),
                       "long_name": f"order power spectrum of {long_name}",
                       "window": str(window), "resolution_order": float(fr.order[1]),
                       "overlap": float(overlap), "scaling": "spectrum"}),
            "n_averages": ("rpm", counts, {"units": "1",
                                           "long_name": "number of frames averaged"}),
        },
        coords=coords,
    )
