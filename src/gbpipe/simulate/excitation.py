"""Designed excitation signals to superpose on a torque or speed set-point.

Two classic identification inputs (Pintelon & Schoukens, *System Identification: A
Frequency Domain Approach*, 2nd ed., 2012, ch. 5):

* a periodic **multisine**: a sum of cosines on the grid ``k / period`` inside a band, with
  a user-set amplitude spectrum and either Schroeder phases (low crest factor, so more rms
  fits under the motors' torque limit) or random phases;
* a **PRBS**: a maximum-length binary sequence (:func:`scipy.signal.max_len_seq`) held
  for one clock period per bit, flat spectrum up to about ``0.3 * clock_hz``.

:func:`within_limits` checks that the set-point plus excitation stays inside a limit
(e.g. the motor torque limit [N·m]) before anything is simulated.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.signal import max_len_seq

from gbpipe.errors import ExcitationError

__all__ = ["MultisineLines", "multisine_lines", "multisine", "prbs", "within_limits"]

#: relative tolerance when a frequency or ratio must land on a whole number of samples
_GRID_RTOL = 1e-9


@dataclass(frozen=True)
class MultisineLines:
    """The spectral lines of a multisine: ``x(t) = sum_k amplitude[k] cos(2 pi
    frequency[k] t + phase[k])``.

    Attributes
    ----------
    frequency : ndarray
        Line frequencies [Hz], ``bins / period``.
    amplitude : ndarray
        Line amplitudes (peak, unit of the set-point, e.g. N·m), scaled to the rms.
    phase : ndarray
        Line phases [rad].
    bins : ndarray
        Line indices ``k`` on the DFT grid of one period.
    period_samples : int
        Samples in one period; the period is ``period_samples / fs`` [s].
    """

    frequency: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    bins: np.ndarray
    period_samples: int


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
    return value


def _record_samples(fs: float, duration: float) -> int:
    """Samples in a record of ``duration`` [s] at ``fs`` [Hz] (as the reference profiles)."""
    fs = _check_positive("fs", fs)
    n = int(round(_check_positive("duration", duration) * fs))
    if n < 2:
        raise ValueError(f"duration: {duration!r} s holds {n} sample(s) at fs = {fs:g} Hz; "
                         "make it at least 2 / fs")
    return n


def _schroeder_phases(power: np.ndarray) -> np.ndarray:
    """Schroeder (1970) phases ``phi_k = -2 pi sum_{l<k} (k - l) p_l`` (``phi_1 = 0``)
    for the power shares ``p`` of consecutive lines ``k = 1..K``."""
    k = np.arange(1, power.size + 1)
    # sum_{l<k} (k - l) p_l = k C_{k-1} - D_{k-1}, C = cumsum(p), D = cumsum(l p): O(K)
    c = np.concatenate(([0.0], np.cumsum(power)[:-1]))
    d = np.concatenate(([0.0], np.cumsum(k * power)[:-1]))
    return np.mod(-2 * np.pi * (k * c - d), 2 * np.pi)


def multisine_lines(fs: float, duration: float, f_min: float, f_max: float, rms: float, *,
                    phases: Literal["schroeder", "random"] = "schroeder",
                    amplitude: Callable[[np.ndarray], np.ndarray | float] | None = None,
                    frequency_resolution: float | None = None,
                    seed: int | None = None) -> MultisineLines:
    """Line frequencies, amplitudes and phases of the multisine of :func:`multisine`.

    Parameters and Raises are those of :func:`multisine`.

    Returns
    -------
    MultisineLines
        The lines; their amplitudes give ``sqrt(sum(amplitude**2) / 2) == rms``.
    """
    n = _record_samples(fs, duration)
    rms = _check_positive("rms", rms)
    if frequency_resolution is None:
        period = n
    else:
        fr = _check_positive("frequency_resolution", frequency_resolution)
        # round down to whole samples, but not 99.999999 -> 99 from a float division
        period = int(np.floor(fs / fr * (1 + _GRID_RTOL)))
        if period > n:
            raise ValueError(f"frequency_resolution: the period 1 / {fr:g} Hz is longer than "
                             f"duration = {duration:g} s; use frequency_resolution >= "
                             f"{1 / duration:g} Hz")
    if not np.isfinite(f_min) or f_min < 0:
        raise ValueError(f"f_min: must be a finite frequency >= 0 Hz, got {f_min!r}")
    if not f_max <= fs / 2:
        raise ValueError(f"f_max: {f_max!r} Hz is above the Nyquist frequency fs / 2 = "
                         f"{fs / 2:g} Hz; lower f_max or raise fs")
    if not f_min < f_max:
        raise ValueError(f"f_min: {f_min!r} Hz must be below f_max = {f_max!r} Hz; "
                         "swap or widen the band")
    # lines strictly between DC and Nyquist: a DC line would shift the set-point and the
    # Nyquist line's cosine depends on the phase (zero for phi = pi / 2)
    k_lo = max(1, int(np.ceil(f_min * period / fs * (1 - _GRID_RTOL))))
    k_hi = min((period - 1) // 2, int(np.floor(f_max * period / fs * (1 + _GRID_RTOL))))
    if k_hi < k_lo:
        raise ValueError(f"f_min, f_max: the band [{f_min:g}, {f_max:g}] Hz holds no line of "
                         f"the grid k * {fs / period:g} Hz between DC and Nyquist; widen the "
                         "band or refine frequency_resolution")
    bins = np.arange(k_lo, k_hi + 1)
    freq = bins * fs / period
    if amplitude is None:
        shape = np.ones(freq.size)
    else:
        shape = np.broadcast_to(np.asarray(amplitude(freq), dtype=float), freq.shape).copy()
        if not np.all(np.isfinite(shape)) or np.any(shape < 0) or not np.any(shape > 0):
            raise ValueError("amplitude: must return finite values >= 0, not all zero, at "
                             "the line frequencies; check the callable")
    power = shape ** 2 / np.sum(shape ** 2)
    if phases == "schroeder":
        phi = _schroeder_phases(power)
    elif phases == "random":
        if seed is None:
            raise ValueError("seed: random phases need an explicit seed (an int) so the "
                             "signal is reproducible; pass seed=...")
        phi = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, freq.size)
    else:
        raise ValueError(f"phases: unknown {phases!r}; use 'schroeder' or 'random'")
    # a cosine of amplitude A has rms A / sqrt(2); distinct lines add in power
    amp = rms * np.sqrt(2 * power)
    return MultisineLines(frequency=freq, amplitude=amp, phase=phi, bins=bins,
                          period_samples=period)


def multisine(fs: float, duration: float, f_min: float, f_max: float, rms: float, *,
              phases: Literal["schroeder", "random"] = "schroeder",
              amplitude: Callable[[np.ndarray], np.ndarray | float] | None = None,
              frequency_resolution: float | None = None,
              seed: int | None = None) -> np.ndarray:
    """Periodic multisine excitation.

    ``x(t) = sum_k A_k cos(2 pi f_k t + phi_k)`` sampled at ``t = i / fs`` with the lines
    ``f_k = k / period`` inside ``[f_min, f_max]``, strictly between DC and ``fs / 2``.
    The period is ``1 / frequency_resolution`` rounded *down* to whole samples, so the
    signal is exactly periodic in samples and the actual grid is ``fs / period_samples``
    (see :func:`multisine_lines`). The record repeats the period; when ``duration`` is not
    a whole number of periods, the last period is cut short (the rms is exact over each
    whole period).

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    duration : float
        Record length [s]; ``round(duration * fs)`` samples.
    f_min, f_max : float
        Band edges [Hz], ``0 <= f_min < f_max <= fs / 2``; lines on the edges are kept.
    rms : float
        Rms of one period, in the unit of the set-point (N·m for torque, rad/s for speed).
    phases : {"schroeder", "random"}, optional
        ``"schroeder"`` (default): Schroeder (1970) phases
        ``phi_k = -2 pi sum_{l<k} (k - l) p_l`` for the power shares ``p_l`` of the
        amplitude spectrum, a low crest factor (about 1.7 for a flat spectrum).
        ``"random"``: independent uniform phases on ``[0, 2 pi)`` from
        ``numpy.random.default_rng(seed)``.
    amplitude : callable, optional
        Relative amplitude spectrum: called with the ndarray of line frequencies [Hz],
        returns relative amplitudes (same shape or a scalar), finite and ``>= 0``. Default:
        flat.
    frequency_resolution : float, optional
        Line spacing [Hz], i.e. ``1 / period``. Default: one period over the whole record.
    seed : int, optional
        Seed of the random phases; required with ``phases="random"``.

    Returns
    -------
    ndarray
        The excitation, ``round(duration * fs)`` samples, unit of ``rms``.

    Raises
    ------
    ValueError
        A non-positive ``fs``, ``duration``, ``rms`` or ``frequency_resolution``; a period
        longer than the record; ``f_max > fs / 2``; ``f_min >= f_max``; no line in the band;
        a bad ``amplitude`` spectrum; unknown ``phases``; random phases without ``seed``.
    """
    lines = multisine_lines(fs, duration, f_min, f_max, rms, phases=phases,
                            amplitude=amplitude, frequency_resolution=frequency_resolution,
                            seed=seed)
    p = lines.period_samples
    # one period by inverse real FFT: bin k of amplitude A and phase phi -> A cos(...)
    spectrum = np.zeros(p // 2 + 1, dtype=complex)
    spectrum[lines.bins] = 0.5 * p * lines.amplitude * np.exp(1j * lines.phase)
    period = np.fft.irfft(spectrum, n=p)
    return np.resize(period, _record_samples(fs, duration))


def prbs(fs: float, duration: float, amplitude: float, *, clock_hz: float,
         seed: int | None = None) -> np.ndarray:
    """Pseudo-random binary sequence: a maximum-length sequence of ``+-amplitude``.

    The bits come from :func:`scipy.signal.max_len_seq`, each held ``fs / clock_hz``
    samples. The register length ``nbits`` is the largest whose period ``2**nbits - 1``
    bits fits in the record, so one period fills as much of it as possible; the rest of
    the record is the start of the next period. Its power spectrum is flat within 1.4 dB
    up to ``0.3 * clock_hz`` (a ``sinc**2`` envelope with zeros at multiples of
    ``clock_hz``).

    Parameters
    ----------
    fs, duration : float
        Sample rate [Hz] and record length [s], as in :func:`multisine`.
    amplitude : float
        Level of a bit, in the unit of the set-point (N·m or rad/s): values ``+-amplitude``.
    clock_hz : float
        Bit rate [Hz], ``<= fs`` with ``fs / clock_hz`` an integer.
    seed : int, optional
        Picks the non-zero initial register state from ``numpy.random.default_rng(seed)``;
        ``None``: all ones (scipy's default).

    Returns
    -------
    ndarray
        The excitation, ``round(duration * fs)`` samples of ``+-amplitude``.

    Raises
    ------
    ValueError
        A non-positive argument, ``fs / clock_hz`` not an integer, or a record shorter than
        the shortest sequence (3 bits).
    """
    n = _record_samples(fs, duration)
    amplitude = _check_positive("amplitude", amplitude)
    clock_hz = _check_positive("clock_hz", clock_hz)
    ratio = fs / clock_hz
    hold = int(round(ratio))
    if hold < 1 or abs(ratio - hold) > _GRID_RTOL * ratio:
        raise ValueError(f"clock_hz: fs / clock_hz = {fs:g} / {clock_hz:g} = {ratio:g} must "
                         f"be an integer >= 1; use clock_hz = fs / m, e.g. {fs / max(hold, 1):g}")
    n_bits = n // hold
    nbits = int(np.floor(np.log2(n_bits + 1)))
    if nbits < 2:
        raise ValueError(f"duration: {n_bits} bit(s) of 1 / clock_hz fit in the record, the "
                         "shortest maximum-length sequence has 3; lengthen duration or raise "
                         "clock_hz")
    nbits = min(nbits, 32)  # longest register scipy knows the taps of
    state = None
    if seed is not None:
        # a random non-zero register state (all zeros would lock the register at zero)
        value = int(np.random.default_rng(seed).integers(1, 2 ** nbits))
        state = (value >> np.arange(nbits)) & 1
    bits = max_len_seq(nbits, state=state)[0]
    one_period = np.repeat(amplitude * (2.0 * bits - 1.0), hold)
    return np.resize(one_period, n)


def within_limits(reference: np.ndarray, excitation: np.ndarray, limit: float, name: str,
                  fs: float | None = None) -> None:
    """Refuse an excitation that drives the set-point beyond a limit.

    Parameters
    ----------
    reference : array_like
        The set-point without excitation (e.g. torque reference [N·m]), 1-D.
    excitation : array_like
        The excitation to add, same shape and unit.
    limit : float
        Largest allowed ``|reference + excitation|`` (e.g. the motor torque limit [N·m]).
    name : str
        Name of the set-point, for the message (e.g. ``"torque_ref"``).
    fs : float, optional
        Sample rate [Hz]; when given, the message also gives the time [s] of the sample.

    Raises
    ------
    ExcitationError
        ``|reference + excitation| > limit`` somewhere: the message names the first such
        sample (and its time), the peak, and the largest factor on the excitation's rms or
        amplitude that would fit (or that the reference alone is beyond the limit).
    ValueError
        Arrays of different shapes or not finite, ``limit`` or ``fs`` not positive.
    """
    ref = np.asarray(reference, dtype=float)
    exc = np.asarray(excitation, dtype=float)
    limit = _check_positive("limit", limit)
    if ref.ndim != 1 or ref.shape != exc.shape:
        raise ValueError(f"excitation: shape {exc.shape} must equal the 1-D shape of "
                         f"reference {ref.shape}; build both on the same time axis")
    if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(exc))):
        raise ValueError(f"{name}: reference or excitation holds NaN or inf; fix the signal")
    total = np.abs(ref + exc)
    over = np.flatnonzero(total > limit)
    if over.size == 0:
        return
    first, peak_at = int(over[0]), int(np.argmax(total))
    when = f" (t = {first / _check_positive('fs', fs):.6g} s)" if fs is not None else ""
    if np.any(np.abs(ref) > limit):
        fix = "the reference alone exceeds the limit: lower the reference, not the excitation"
    else:
        # r + s e stays in [-L, L] for s <= (L - sign(e) r) / |e| at every sample
        moving = exc != 0
        scale = np.min((limit - np.sign(exc[moving]) * ref[moving]) / np.abs(exc[moving]))
        fix = (f"lower the excitation rms or amplitude by a factor <= {scale:.4g} "
               "(or move the reference away from the limit)")
    raise ExcitationError(
        f"{name}: |reference + excitation| exceeds the limit {limit:.6g} first at sample "
        f"{first}{when}; peak {total[peak_at]:.6g} at sample {peak_at}; {fix}")
