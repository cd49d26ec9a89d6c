"""On-disk form of each variable (used by :func:`gbpipe.io.write`): codec and precision.

Compression
    Every numeric array is stored with zlib level 1 after HDF5's byte shuffle. The bulk of
    the outputs is float time series whose exponent and leading mantissa bytes change
    slowly: shuffled, zlib's level 1 takes 40-70 % off them (regular time axes and
    piecewise-linear references 30-200 times), levels above 1 add about 2 % for 1.5-3
    times the CPU. zlib is the one codec every netCDF-4 reader decodes without a plugin;
    zstd (netCDF4-python 1.7 drops the shuffle before it, so it compresses less) and
    blosc (its HDF5 filter fails on a chunk it cannot compress) were measured and not
    taken. Strings (variable-length: HDF5 filters do not apply) and scalars are left alone.
Precision
    A float64 variable is stored as float32 when the producer asks for it for every
    variable (``float32=True``: the stage knows its data need no more), or when the
    producer names it as *noisy* (a measurement or measured-like series) and the data
    show that float32 costs nothing: the rounding error's power spectral density lies at
    least :data:`MARGIN_DB` below the series' own at every frequency
    (:func:`rounding_margin_db`). Rounding then raises the series' spectrum, and so its
    noise floor, by at most 10^(-MARGIN_DB/10) (0.01 %, 0.0004 dB) anywhere. A noisy
    series without noise (a sensor-noise level of 0, a record that holds only a smooth
    response) fails the test and stays float64. The variable's ``comment`` says what
    float32 cost, computed from the variable itself.
Rounding step
    A noisy series stored as float32 is first rounded to a step q (:func:`quantum`): the
    largest power of two whose white rounding error (variance q^2/12) lies MARGIN_DB
    under the series' noise floor (the smallest band of its spectrum). An absolute step,
    as an ADC's, not a relative one: a residual about 0 with raw edges at 16 kN·m is
    rounded as finely everywhere. The multiples of a power of two leave the low mantissa
    bits zero (a value v keeps log2(|v|/q) of them), which the shuffled zlib stream all
    but removes: a torque with 10 N·m of noise at 16 kN·m keeps 16 of float32's 23
    bits, and its stored series shrinks by a third. netCDF-C's BitRound, the library's
    own quantisation, keeps a number of bits relative to each value instead, and marks
    the variable with ``_QuantizeBitRoundNumberOfSignificantBits``, a name CF forbids.
"""

from __future__ import annotations

from collections.abc import Collection
from functools import lru_cache
from typing import Any

import numpy as np
import xarray as xr
from scipy.fft import rfft

__all__ = ["MARGIN_DB", "quantum", "rounding_margin_db", "storage"]

#: Least distance [dB] between a noisy series' power spectral density and its float32
#: rounding error's, at every frequency, for float32 storage.
MARGIN_DB = 40.0
# Frequency bands of the margin: 512 bands resolve notches down to 1/512 of the Nyquist
# band; each averages the periodogram lines it holds (at least _LINES, else fewer bands).
_BANDS = 512
_LINES = 16
_DEFLATE = {"zlib": True, "complevel": 1, "shuffle": True}


@lru_cache(maxsize=4)
def _hann(n: int) -> np.ndarray:
    # the records of a job share a few lengths; the window's cosines cost as much as an FFT
    window = np.hanning(n).astype(np.float32)
    window.flags.writeable = False
    return window


def _band_psd(x: np.ndarray, bands: int) -> np.ndarray:
    # Hann-windowed periodogram of the whole series, averaged over contiguous bands of
    # lines (Daniell): the variance of Welch's method at a fraction of its CPU, and less
    # leakage (Welch's short segments spread their sidelobes over many Hz). In single
    # precision: the FFT's own rounding lies at float32's, at or below the rounding error
    # whose spectrum it is compared with, so it cannot lift a margin over MARGIN_DB.
    centred = (x - x.mean(axis=-1, keepdims=True)).astype(np.float32)
    spec = rfft(centred * _hann(x.shape[-1]), axis=-1)[..., 1:]
    lines = (spec.real.astype(np.float64) ** 2 + spec.imag.astype(np.float64) ** 2)
    edges = np.linspace(0, lines.shape[-1], bands + 1).astype(int)[:-1]
    return np.add.reduceat(lines, edges, axis=-1) / np.diff(edges, append=lines.shape[-1])


def rounding_margin_db(values: np.ndarray, axis: int = -1) -> float:
    """How far float32 rounding lies below a series, at its closest frequency [dB].

    Parameters
    ----------
    values : numpy.ndarray
        A float series (any unit), sampled along ``axis``.
    axis : int, default -1
        The sample axis.

    Returns
    -------
    float
        The minimum over frequency (and over any other axis) of 10 log10 of the power
        spectral density of ``values`` over that of its float32 rounding error
        ``values - float32(values)``, both estimated alike (Hann-windowed periodogram
        above 0 Hz averaged over up to 512 contiguous bands of at least 16 lines);
        ``inf`` if float32 represents every value exactly, ``nan`` if a value is not
        finite or the series is shorter than 34 samples. Below :data:`MARGIN_DB`, the
        ratio of the total powers is returned instead when it is that low already (an
        upper bound of the minimum, which then needs no spectra). The spectra are
        computed in single precision, whose own rounding lies near float32's: margins
        near or below 0 dB (smooth series) come out too high, by up to ~25 dB, but
        still far below :data:`MARGIN_DB`; margins of 20 dB and more are exact.
    """
    return _margin(values, axis)[0]


def _margin(values: np.ndarray, axis: int) -> tuple[float, np.ndarray | None]:
    """:func:`rounding_margin_db`, and the banded spectrum of ``values`` where it was
    computed (else None): :func:`quantum` needs the same one."""
    x = np.moveaxis(np.asarray(values, dtype=np.float64), axis, -1)
    bands = min(_BANDS, (x.shape[-1] // 2) // _LINES)
    if bands < 1 or not np.all(np.isfinite(x)):
        return float("nan"), None
    with np.errstate(over="ignore", invalid="ignore"):
        err = x - x.astype(np.float32).astype(np.float64)
    if not np.all(np.isfinite(err)):  # beyond float32's range
        return float("nan"), None
    if not np.any(err):
        return float("inf"), None
    # The smallest ratio over frequency is at most the ratio of the total powers: where
    # that is already below MARGIN_DB (a smooth series), it is returned, without spectra.
    with np.errstate(divide="ignore", invalid="ignore"):
        total = float(np.min(np.where(np.var(err, axis=-1) > 0,
                                      np.var(x, axis=-1) / np.var(err, axis=-1), np.inf)))
    if total < 10 ** (MARGIN_DB / 10):
        return (float(10.0 * np.log10(total)) if total > 0 else float("-inf")), None
    pxx, pee = _band_psd(x, bands), _band_psd(err, bands)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(pee > 0, pxx / pee, np.inf)
        return float(10.0 * np.log10(np.min(ratio))), pxx


def quantum(values: np.ndarray, axis: int = -1, *, psd: np.ndarray | None = None) -> float:
    """The step a noisy series is rounded to before it is stored [its unit].

    Parameters
    ----------
    values, axis
        As for :func:`rounding_margin_db`.
    psd : numpy.ndarray, optional
        The banded spectrum of ``values`` that :func:`rounding_margin_db` computed on the
        way (the same numbers; a whole-series FFT not done twice).

    Returns
    -------
    float
        The largest power of two q whose rounding error (uniform, white, variance
        q^2 / 12) lies :data:`MARGIN_DB` under the series' noise floor: the smallest
        band of its power spectral density above 0 Hz (estimated as in
        :func:`rounding_margin_db`), as the variance of white noise with that density.
        An absolute step, as an ADC's: the bulk of a residual about 0 and its raw
        edges at 16 kN·m are rounded alike, each as finely as the noise asks. 0.0 where
        the series has no floor to measure (too short, not finite, a band of zero power).
    """
    x = np.moveaxis(np.asarray(values, dtype=np.float64), axis, -1)
    bands = min(_BANDS, (x.shape[-1] // 2) // _LINES)
    if bands < 1 or not np.all(np.isfinite(x)):
        return 0.0
    # a white series of variance v has periodogram lines v times the window's energy
    energy = float(np.sum(_hann(x.shape[-1]).astype(np.float64) ** 2))
    floor = float(np.min(_band_psd(x, bands) if psd is None else psd)) / energy
    if not floor > 0.0:
        return 0.0
    return float(2.0 ** np.floor(np.log2(np.sqrt(12.0 * floor) * 10 ** (-MARGIN_DB / 20))))


def _float32_note(var: xr.DataArray, stored: np.ndarray, margin: float | None,
                  step: float) -> str:
    x = np.asarray(var.values, dtype=np.float64)
    err = np.abs(x - stored.astype(np.float64))
    units = var.attrs.get("gbpipe_units", var.attrs.get("units", ""))
    worst = float(np.max(err)) if err.size else 0.0
    top = float(np.max(np.abs(x))) if x.size else 0.0
    kind = f"float32, rounded to multiples of {step:.6g} {units}" if step else "float32"
    text = (f"stored as {kind}: rounding error at most {worst:.3g} {units}, "
            f"{worst / top if top else 0.0:.2g} of the largest magnitude {top:.6g} {units}")
    if margin is None:
        return f"{text} (the producing stage's choice for every variable)."
    return (f"{text}; float32's rounding lies {margin:.0f} dB below the series' power "
            f"spectral density at every frequency above 0 Hz (a noisy series is stored as "
            f"float32 only from {MARGIN_DB:.0f} dB), and the step's white rounding error "
            f"{MARGIN_DB:.0f} dB or more below its noise floor.")


def storage(out: xr.Dataset, float32: bool, noisy: Collection[str],
            sample_dim: str) -> tuple[xr.Dataset, dict[str, dict[str, Any]]]:
    """The ``to_netcdf`` encoding of each variable, and the dataset with its notes.

    Parameters
    ----------
    out : xarray.Dataset
        The dataset in its CF form (:func:`gbpipe.io.cf.encode`).
    float32 : bool
        Store every float64 data variable as float32.
    noisy : collection of str
        Data variables on ``sample_dim`` to store as float32 where
        :func:`rounding_margin_db` along ``sample_dim`` reaches :data:`MARGIN_DB`, with
        the values rounded to the step :func:`quantum` gives (also under ``float32``).
    sample_dim : str
        The on-disk name of the time axis.

    Returns
    -------
    out : xarray.Dataset
        ``out`` with each variable stored as float32 in float32 (a noisy one rounded to
        its step), and a ``comment`` saying what that cost.
    encoding : dict
        Per variable: ``dtype``, compression and ``_FillValue``.

    Raises
    ------
    ValueError
        A name in ``noisy`` is not a data variable on ``sample_dim``.
    """
    wrong = sorted(n for n in noisy if n not in out.data_vars or sample_dim not in out[n].dims)
    if wrong:
        raise ValueError(f"noisy={wrong}: not data variables on the time axis of the dataset "
                         "(name measured time series only)")
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        enc: dict[str, Any] = {}
        if name in out.coords or var.dtype.kind in "iubUS" or var.dtype == object:
            # CF forbids missing coordinate values; integers and strings have no NaN
            enc["_FillValue"] = None
        if var.dtype == np.float64 and name in out.data_vars:
            margin, psd = (_margin(var.values, var.get_axis_num(sample_dim))
                           if name in noisy else (None, None))
            if float32 or (margin is not None and margin >= MARGIN_DB):
                enc["dtype"] = "float32"
                # a stage's float32 series named noisy too is rounded as its noise allows
                roomy = margin if margin is not None and margin >= MARGIN_DB else None
                step = (quantum(var.values, var.get_axis_num(sample_dim), psd=psd)
                        if roomy else 0.0)
                exact = np.asarray(var.values, dtype=np.float64)
                with np.errstate(over="ignore"):
                    stored = (np.round(exact / step) * step if step else exact).astype(
                        np.float32)
                note = _float32_note(var, stored, roomy, step)
                attrs = dict(var.attrs)
                attrs["comment"] = f"{attrs['comment']}\n{note}" if "comment" in attrs else note
                out[name] = var.copy(data=stored)
                out[name].attrs = attrs
        if var.ndim and var.size > 1 and var.dtype.kind in "iufcb":
            enc.update(_DEFLATE)
        encoding[name] = enc
    return out, encoding
