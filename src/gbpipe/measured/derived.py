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
    like any channel, ``value * scale + offset`` pulses) gives one pulse per whole pulse
    counted, timed by linear interpolation between the two samples that bracket it, with
    the count taken half a count above its floor (one-sample resolution is all a sampled
    counter knows); a cumulative encoder angle (``tacho: angle``) gives a pulse every
    ``2π / pulses_per_rev``, timed by linear interpolation (exact at constant speed within
    a sample; otherwise off by about α·dt²/(8ω) [s] at angular acceleration α).
"""

from __future__ import annotations

import logging

import numpy as np
from scipy.signal import freqz, savgol_coeffs, savgol_filter

from gbpipe.errors import DataError
from gbpipe.harmonics.tacho import pulse_times_from_tacho
from gbpipe.measured.spec import SignalSpec

__all__ = ["speed_from_angle", "savgol_window", "pulse_times", "whole_counts", "crossings",
           "POLYORDER",
           "GAIN_TOL", "BAND"]

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
    """Pulse times [s] (on the clock of ``t0``) from a tacho channel, as ``sig`` says.

    ``tacho: analog``: a voltage (Schmitt trigger). ``tacho: count``: a cumulative counter
    in whole counts; ``value * scale + offset`` is the number of pulses. ``tacho: angle``:
    a cumulative angle [rad] (already converted), a pulse every ``2π / pulses_per_rev``.

    Raises
    ------
    gbpipe.errors.DataError
        A count or an angle that decreases, or an analog threshold outside the signal;
        naming the sample and the fix (whole counts: :func:`whole_counts`).
    """
    if sig.tacho == "count":
        # a counter floors the true count: the best estimate is half a count above
        # (bridged samples, between whole counts, are on the same straight line)
        position = values * sig.scale + sig.offset + 0.5 * abs(sig.scale)
        what = "pulse count (value * scale + offset)"
    elif sig.tacho == "angle":
        position = values * (sig.pulses_per_rev / (2.0 * np.pi))
        what = "encoder angle"
    else:
        try:
            return pulse_times_from_tacho(values, 1.0 / dt, threshold=sig.threshold,
                                          hysteresis=sig.hysteresis, edge=sig.edge, t0=t0)
        except ValueError as exc:
            raise DataError(f"{source}: field 'threshold'/'hysteresis'", str(exc)) from exc
    return t0 + dt * crossings(position, source, what)


def whole_counts(values: np.ndarray, source: str) -> None:
    """Refuse a ``tacho: count`` channel whose values are not whole counts (checked on the
    samples as read, before NaN runs or time gaps are bridged).

    Raises
    ------
    gbpipe.errors.DataError
        At the first value that is not a whole count, with the fix.
    """
    off = np.abs(values - np.rint(values)) > 1e-9 * np.maximum(1.0, np.abs(values))
    if off.any():
        i = int(np.argmax(off))
        raise DataError(f"{source}: field 'tacho'", f"value {values[i]:.9g} is not a whole "
                        f"count: tacho: count needs a counter of whole counts (use scale: "
                        f"for counts per pulse); a cumulative encoder angle is tacho: "
                        f"angle with its unit:", sample=i)


def crossings(position: np.ndarray, source: str, what: str) -> np.ndarray:
    """Fractional sample indices where a non-decreasing ``position`` [pulses] reaches each
    whole number, by linear interpolation between the two samples that bracket it (exact
    when the position moves at a constant rate between them).

    Raises
    ------
    gbpipe.errors.DataError
        At the first sample where ``position`` decreases.
    """
    back = np.flatnonzero(np.diff(position) < 0)
    if back.size:
        raise DataError(source, f"the {what} decreases (a counter reset or wrap, a wrapped "
                        f"angle, or reverse rotation): a tacho needs a cumulative, "
                        f"increasing position; for reverse rotation give scale: -1",
                        sample=int(back[0]) + 1)
    marks = np.arange(np.floor(position[0]) + 1.0, np.floor(position[-1]) + 1.0)
    after = np.searchsorted(position, marks, side="left")  # first sample >= each mark
    below = position[after - 1]
    return after - 1 + (marks - below) / (position[after] - below)
