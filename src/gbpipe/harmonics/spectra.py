"""Spectra of rotating-machine signals vs shaft speed (waterfalls).

* :func:`power_spectrum_vs_rpm` -- power spectrum vs frequency [Hz] and rpm (paper Fig 11);
* :func:`order_spectrum_vs_rpm` -- order spectrum vs order [-] and rpm (Figs 13, 15, 17);
* :func:`order_spectrum` -- order spectrum of a whole record.

Both cut the record into windowed frames (in time, or in shaft angle after order
tracking) with :class:`scipy.signal.ShortTimeFFT` (frame ``k`` starts at sample
``k * hop``; only whole frames), give every frame its mean speed, and average the frame
periodograms within each rpm bin. They return an :class:`xarray.Dataset` with
coordinates ``rpm`` [rev/min] (bin centres, with ``rpm_lower``/``rpm_upper`` edges)
and ``frequency`` [Hz] or ``order`` [-], a ``power`` variable and the number of frames
averaged per bin ``n_averages``; every variable and coordinate carries ``units`` and ``long_name``.

Scaling. ``scaling="spectrum"`` (default) is a power spectrum in signal units squared
(e.g. "N2 m2" for a torque in "N m"): a sinusoid of amplitude A centred on a bin shows
A**2 / 2, i.e. its mean square -- what the paper's Fig 11 plots in dB and what Testlab
calls an autopower "RMS" spectrum. Broadband noise level then depends on the resolution.
``scaling="density"`` gives a PSD in units squared per Hz (sinusoids then depend on the
resolution). Order spectra are power spectra only (a density per order is rarely wanted).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import xarray as xr
from scipy import fft as sfft
from scipy.signal import ShortTimeFFT

from gbpipe.harmonics.angle import angle_map, resample_map_to_angle
from gbpipe.harmonics.binning import bin_average, rpm_coords, rpm_edges
from gbpipe.harmonics.checks import (
    as_positive,
    as_pulses,
    as_signal,
    check_overlap,
    check_within_record,
    get_window,
)
from gbpipe.harmonics.tacho import AngleMethod, shaft_angle
from gbpipe.units import RPM_PER_RAD_S, TWO_PI, squared_units

__all__ = ["power_spectrum_vs_rpm", "order_spectrum_vs_rpm", "order_spectrum"]


def _frame_power(x: np.ndarray, nper: int, overlap: float, window: str | tuple, fs: float,
                 scale_to: Literal["magnitude", "psd"]) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """One-sided power of every whole frame of ``nper`` samples of ``x``.

    Returns the power (frames, frequencies), the frequencies [unit of ``fs``] and the
    first sample of each frame. ``scale_to="magnitude"``: a sinusoid of amplitude A on a
    bin shows A**2/2 (power spectrum); ``"psd"``: power spectral density.
    """
    hop = max(1, int(round(nper * (1.0 - overlap))))
    n_frames = (x.size - nper) // hop + 1
    stft = ShortTimeFFT(get_window(window, nper), hop, fs, fft_mode="onesided",
                        scale_to=scale_to)
    # ShortTimeFFT centres slice p on sample p * hop; the offset of half a window makes
    # slice p start there instead, so only whole frames inside the record are used.
    spec = stft.spectrogram(x, p0=0, p1=n_frames, k_offset=stft.m_num_mid).T
    # Double every bin but DC (and Nyquist for even nper): one-sided power.
    spec[:, 1:] *= 2.0
    if nper % 2 == 0:
        spec[:, -1] /= 2.0
    return spec, stft.f, hop * np.arange(n_frames)


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
    method: AngleMethod = "pchip",
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
        Passed to :func:`gbpipe.harmonics.shaft_angle` when ``pulse_times`` is used.
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
    DataError, PulseError
        Bad signal, speed or pulse times.
    """
    x = as_signal(x)
    fs = as_positive(fs, "fs", "Hz")
    resolution = as_positive(resolution, "resolution", "Hz")
    overlap = check_overlap(overlap)
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
    scale_to = "magnitude" if scaling == "spectrum" else "psd"
    spec, freq, starts = _frame_power(x, nper, overlap, window, fs, scale_to)
    if rpm is not None:
        r = as_signal(rpm, "rpm")
        if r.size != x.size:
            raise ValueError(f"rpm must have one value per sample of x ({x.size}); got {r.size}")
        cs = np.concatenate([[0.0], np.cumsum(r)])
        rpm_frame = (cs[starts + nper] - cs[starts]) / nper
    else:
        p = as_pulses(pulse_times)
        check_within_record(p, float(t0), fs, x.size)
        ta = t0 + starts / fs
        tb = t0 + (starts + nper - 1) / fs
        th = shaft_angle(np.concatenate([ta, tb]), p, pulses_per_rev=pulses_per_rev,
                         method=method)
        rpm_frame = (th[starts.size:] - th[:starts.size]) / (tb - ta) * RPM_PER_RAD_S
    edges = rpm_edges(rpm_frame, rpm_bins)
    if scaling == "spectrum":
        unit = squared_units(units)
        what = "power spectrum"
    else:
        unit = f"{squared_units(units)} Hz-1" if squared_units(units) != "1" else "Hz-1"
        what = "power spectral density"
    if max_frequency is not None:
        keep = freq <= max_frequency
        freq, spec = freq[keep], spec[:, keep]
    mean, counts = bin_average(spec, rpm_frame, edges)
    coords = rpm_coords(edges)
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
    x, fs, p, ppr, amap = angle_map(x, fs, pulse_times, pulses_per_rev, method, t0)
    resolution = as_positive(resolution, "resolution", "orders")
    max_order = as_positive(max_order, "max_order", "orders")
    overlap = check_overlap(overlap)
    spr = int(sfft.next_fast_len(int(np.ceil(2.5 * max_order))))  # max order at 0.4 x spr
    theta, xa = resample_map_to_angle(x, amap, spr)
    spr = int(round(TWO_PI / theta[1]))
    nper = int(round(spr / resolution))
    if nper > xa.size:
        raise ValueError(
            f"resolution={resolution} orders needs frames of {1 / resolution:.3g} revolutions "
            f"but the pulses span {theta[-1] / TWO_PI:.3g}: choose a coarser resolution"
        )
    spec, order, starts = _frame_power(xa, nper, overlap, window, float(spr), "magnitude")
    # Mean speed of a frame: its angle span over its duration; times of the frame ends by
    # inverse interpolation of the sampled angle (a handful of points).
    ta = np.interp(theta[starts], amap.theta, amap.sample_times)
    tb = np.interp(theta[starts + nper - 1], amap.theta, amap.sample_times)
    rpm_frame = (theta[starts + nper - 1] - theta[starts]) / (tb - ta) * RPM_PER_RAD_S
    return _OrderFrames(spec, order, rpm_frame)


def order_spectrum_vs_rpm(
    x: np.ndarray, fs: float, pulse_times: np.ndarray, *, resolution: float = 0.1,
    max_order: float = 40.0, window: str | tuple = "hann", overlap: float = 0.5,
    rpm_bins: int | np.ndarray = 36, pulses_per_rev: int = 1, t0: float = 0.0,
    method: AngleMethod = "pchip", units: str = "1", long_name: str = "signal",
) -> xr.Dataset:
    """Order power spectrum vs order and shaft speed (order waterfall).

    The record is resampled at constant angle of the tachometer shaft without aliasing
    (:func:`gbpipe.harmonics.resample_to_angle`, low-passed to about ``1.25 * max_order``),
    cut into frames of ``1 / resolution`` revolutions, windowed; frame periodograms are
    averaged per rpm bin. A component ``A cos(m theta)`` on an order bin shows ``A**2/2``.

    Parameters
    ----------
    x, fs, pulse_times, pulses_per_rev, t0, method
        As in :func:`gbpipe.harmonics.resample_to_angle`.
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
    edges = rpm_edges(fr.rpm, rpm_bins)
    mean, counts = bin_average(fr.power[:, keep], fr.rpm, edges)
    coords = rpm_coords(edges)
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


def order_spectrum(x: np.ndarray, fs: float, pulse_times: np.ndarray, *,
                   resolution: float = 0.05, max_order: float = 50.0,
                   **options: Any) -> xr.DataArray:
    """Averaged order power spectrum of a whole record.

    The order waterfall of :func:`order_spectrum_vs_rpm` with a single speed bin: every
    frame of the record is averaged. Scaling is a power spectrum: a component
    ``A cos(m theta)`` at an order bin shows ``A**2 / 2``.

    Parameters
    ----------
    x, fs, pulse_times
        As in :func:`gbpipe.harmonics.resample_to_angle`.
    resolution : float
        Order resolution [-] (bin spacing); frames span ``1 / resolution`` revolutions.
    max_order : float
        Highest order kept [-].
    **options
        ``window``, ``overlap``, ``pulses_per_rev``, ``t0``, ``method``, ``units``,
        ``long_name``, as in :func:`order_spectrum_vs_rpm`.

    Returns
    -------
    xarray.DataArray
        Dimension ``order`` [-]; attrs ``units``, ``long_name``, ``n_averages``.
    """
    ds = order_spectrum_vs_rpm(x, fs, pulse_times, resolution=resolution,
                               max_order=max_order, rpm_bins=1, **options)
    da = ds["power"].isel(rpm=0, drop=True).drop_vars(["rpm_lower", "rpm_upper"],
                                                      errors="ignore")
    da.attrs = {"units": da.attrs["units"], "long_name": da.attrs["long_name"],
                "n_averages": int(ds["n_averages"].values[0])}
    return da
