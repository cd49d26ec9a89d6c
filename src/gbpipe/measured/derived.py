"""Quantities a record stores that the bench measures indirectly.

``quantity: angle``
    A cumulative encoder angle [rad] becomes shaft speed [rad/s] by a Savitzky–Golay
    derivative on the source samples, *before* resampling. Why: a derivative multiplies
    noise at frequency f by 2πf, so what matters is (i) to be the exact derivative in
    the band the record keeps, where no method can remove the noise without removing
    signal, and (ii) not to pass the amplified noise above that band. Differencing
    *after* resampling fails (i): at the record rate, a central difference has gain
    sin(ωT)/(ωT), 0.50 at 0.3 fs. The Savitzky–Golay filter is a local least-squares
    polynomial, exact for polynomials up to :data:`POLYORDER`; :func:`savgol_window`
    takes the longest window whose derivative gain stays within :data:`GAIN_TOL` of
    ``jω`` up to :data:`BAND` × the record's Nyquist frequency, so (i) holds, and the
    resampler's anti-aliasing filter then removes the noise above the band (ii). When
    the source is not oversampled (source rate ≈ record rate) no window meets the
    tolerance; the 5-point cubic is used (gain 0.995 at 0.1 fs, 0.93 at 0.2 fs — still
    better than a difference's 0.94 and 0.76) and a warning says so.
``quantity: tacho``
    An analog tacho voltage becomes pulse times through
    :func:`gbpipe.harmonics.tacho.pulse_times_from_tacho` (threshold with hysteresis,
    sub-sample crossing); a pulse-count channel (``tacho: count``, a counter sampled
    like any channel) gives one pulse per count increment, timed between the two
    samples that bracket it (one-sample resolution is all a sampled counter knows).
"""

from __future__ import annotations

import logging

import numpy as np
from scipy.signal import freqz, savgol_coeffs, savgol_filter

from gbpipe.errors import DataError
from gbpipe.harmonics.tacho import pulse_times_from_tacho
from gbpipe.measured.spec import SignalSpec

__all__ = ["speed_from_angle", "savgol_window", "pulse_times", "POLYORDER", "GAIN_TOL",
           "BAND"]

log = logging.getLogger(__name__)

POLYORDER = 3
GAIN_TOL = 1e-3
BAND = 0.8
_MAX_WINDOW = 201


def savgol_window(src_fs: float, record_fs: float) -> int:
    """Longest odd Savitzky–Golay window (≥ 5) whose derivative gain is within
    :data:`GAIN_TOL` (relative) of ``jω`` up to ``BAND * record_fs / 2``."""
    f_band = min(BAND * record_fs / 2.0, BAND * src_fs / 2.0)
    f = np.linspace(f_band / 64, f_band, 64)
    best = POLYORDER + 2 if (POLYORDER + 2) % 2 else POLYORDER + 3
    for n in range(best, _MAX_WINDOW + 1, 2):
        c = savgol_coeffs(n, POLYORDER, deriv=1, delta=1.0 / src_fs, use="conv")
        _, h = freqz(c, worN=f, fs=src_fs)
        # freqz of a centred (non-causal) kernel: remove the (n-1)/2-sample delay
        h = h * np.exp(1j * 2 * np.pi * f * (n - 1) / 2 / src_fs)
        err = np.max(np.abs(h / (1j * 2 * np.pi * f) - 1.0))
        if err > GAIN_TOL:
            if n == best:
                log.warning("encoder at %g Hz into a %g Hz record: the %d-point derivative "
                            "is off by %.2g %% at %g Hz (oversample the encoder to keep "
                            "the band exact)", src_fs, record_fs, n, 100 * err, f_band)
            break
        best = n
    return best


def speed_from_angle(angle: np.ndarray, dt: float, record_fs: float) -> np.ndarray:
    """Shaft speed [rad/s] from a cumulative angle [rad] sampled every ``dt`` [s]."""
    n = savgol_window(1.0 / dt, record_fs)
    if angle.size < n:
        n = angle.size - (1 - angle.size % 2)  # longest odd window that fits
    return savgol_filter(angle, n, POLYORDER, deriv=1, delta=dt, mode="interp")


def pulse_times(values: np.ndarray, t0: float, dt: float, sig: SignalSpec,
                source: str) -> np.ndarray:
    """Pulse times [s] (on the clock of ``t0``) from a tacho channel, as ``sig`` says."""
    if sig.tacho == "count":
        steps = np.diff(values)
        if np.any(steps < 0):
            i = int(np.flatnonzero(steps < 0)[0])
            raise DataError(source, "pulse count decreases (counter reset or wrap): "
                            "field 'tacho: count' needs a cumulative count", sample=i + 1)
        steps = np.rint(steps).astype(np.int64)
        idx = np.repeat(np.arange(steps.size), steps)
        # n pulses between samples k and k+1: spread evenly inside the interval
        within = np.arange(idx.size) - np.repeat(np.cumsum(steps) - steps, steps)
        return t0 + (idx + (within + 0.5) / np.repeat(steps, steps)) * dt
    try:
        return pulse_times_from_tacho(values, 1.0 / dt, threshold=sig.threshold,
                                      hysteresis=sig.hysteresis, edge=sig.edge, t0=t0)
    except ValueError as exc:
        raise DataError(f"{source}: field 'threshold'/'hysteresis'", str(exc)) from exc
