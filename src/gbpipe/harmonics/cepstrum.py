"""Cepstral editing (Randall and Sawalhi 2011): comb liftering of the families' rahmonics.

A family of harmonics of a cycle ``c`` [orders] is a comb in the log-amplitude spectrum,
with period ``c``; in the real cepstrum (inverse FFT of the log amplitude) it is a
series of peaks, the rahmonics, at quefrencies ``m / c`` revolutions. Setting them to zero
(a comb lifter) and transforming back flattens the comb to the level between the teeth,
i.e. to the broadband floor; the edited amplitude is combined with the original phase
and transformed back to a signal.

Done frame by frame (:class:`scipy.signal.ShortTimeFFT`, Hann, 75 % overlap) in the
angle domain, where every order is a fixed line whatever the speed
(:mod:`gbpipe.harmonics.angle`). Only the difference between the record and its edited
version, i.e. the removed harmonics, is brought back to the time samples and subtracted
(:func:`gbpipe.harmonics.removal_inputs.subtract_angle_part`), and only within ``band``
orders of the families' orders: elsewhere the edit would reshape the broadband spectrum
(a comb lifter also removes any ripple of period ``c`` in the log spectrum).

Cepstral editing is nonlinear: a line is brought down to about the random floor of its
bin, not below; its attenuation is about its line-to-random ratio per bin, in dB.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

import numpy as np
from scipy import fft as sfft
from scipy import signal

from gbpipe.harmonics.checks import as_count, as_positive
from gbpipe.harmonics.removal_inputs import (
    Families,
    family_cycle,
    removal_inputs,
    subtract_angle_part,
    to_angle,
)
from gbpipe.harmonics.tacho import AngleMethod

__all__ = ["comb_lifter", "residual_cepstrum"]


def comb_lifter(n_fft: int, samples_per_rev: float, cycles: Sequence[float | Fraction],
                width: int) -> np.ndarray:
    """Comb lifter of an ``n_fft``-point real cepstrum: 0 at the rahmonics, 1 elsewhere.

    Parameters
    ----------
    n_fft : int
        Cepstrum length [samples].
    samples_per_rev : float
        Quefrency samples per revolution (the angle-domain points per revolution when the
        cepstrum spans the whole spectrum; fewer for the cepstrum of a low band).
    cycles : sequence of float or Fraction
        Cycle order of each family [HSS orders]; rahmonics at ``m / c`` revolutions.
    width : int
        Quefrency samples zeroed either side of each rahmonic's nearest sample.

    Returns
    -------
    numpy.ndarray, shape (n_fft,)
        The lifter (symmetric: the cepstrum of a real log spectrum is even).
    """
    lifter = np.ones(n_fft)
    for c in cycles:
        period = samples_per_rev / float(c)  # quefrency samples between rahmonics
        q = period * np.arange(1, int(np.floor(0.5 * n_fft / period)) + 1)
        idx = np.round(q).astype(int)[:, None] + np.arange(-width, width + 1)[None, :]
        idx = idx[(idx > 0) & (idx <= n_fft // 2)]
        lifter[idx] = 0.0
        lifter[n_fft - idx] = 0.0
    return lifter


def residual_cepstrum(x: np.ndarray, fs: float, pulse_times: np.ndarray, families: Families,
                      pulses_per_rev: int = 1, *, frame_revs: int = 16, width: int = 1,
                      band: float = 0.125, samples_per_rev: int | None = None,
                      t0: float = 0.0, method: AngleMethod = "pchip") -> np.ndarray:
    """Remove order families by cepstral editing in the angle domain.

    Parameters
    ----------
    x, fs, pulse_times, families, pulses_per_rev, t0, method
        The common signature (:func:`gbpipe.harmonics.removal.remove_harmonics`).
        A family's cycle is the greatest common divisor of its orders
        (:func:`gbpipe.harmonics.removal_inputs.family_cycle`).
    frame_revs : int
        Frame length [revolutions]: order resolution ``1 / frame_revs``.
    width : int
        Quefrency samples zeroed either side of each rahmonic.
    band : float
        Edited spectrum kept only within ``band`` orders of the families' orders.
    samples_per_rev : int, optional
        Angle-domain points per revolution; default 16 per period of the highest order.

    Returns
    -------
    numpy.ndarray
        The residual: ``x`` minus the liftered lines (unit of ``x``).

    Raises
    ------
    ValueError
        Record shorter than one frame; bad counts or band.
    """
    rec, fam, orders = removal_inputs(x, fs, pulse_times, families, pulses_per_rev, t0,
                                      method)
    frame_revs = as_count(frame_revs, "frame_revs", 2)
    width = as_count(width, "width", 0)
    band = as_positive(band, "band", "orders")
    xa, spr = to_angle(rec, float(orders.max()), samples_per_rev)
    n_fft = frame_revs * spr
    if xa.size < n_fft:
        raise ValueError(f"the record spans {xa.size / spr:.1f} revolutions, less than one "
                         f"frame of frame_revs={frame_revs}: shorten frame_revs")
    stft = signal.ShortTimeFFT(signal.windows.hann(n_fft, sym=False), n_fft // 4,
                               fs=float(spr))
    spec = stft.stft(xa)
    amp = np.abs(spec)
    for name, ords in fam.items():  # one family after the other, each on its own band
        cycle = float(family_cycle(list(families[name])))
        # the cepstrum of the log spectrum from order 0 to just past the family: its comb
        # then fills the transform, and the lifter removes it whole
        k = min(int(np.ceil((ords.max() + 0.5 * cycle + band) * frame_revs)) + 1, amp.shape[0])
        n_c = 2 * (k - 1)
        ceps = sfft.irfft(np.log(np.maximum(amp[:k], np.finfo(float).tiny)), n_c, axis=0)
        ceps *= comb_lifter(n_c, n_c / frame_revs, [cycle], width)[:, None]
        near = (np.abs(stft.f[:k, None] - ords[None, :]) <= band).any(axis=1)
        amp[:k][near] = np.exp(sfft.rfft(ceps, axis=0).real)[near]
    # removed part only: the edited amplitude with the original phase, minus the original
    removed = spec - amp * np.exp(1j * np.angle(spec))
    discrete = stft.istft(removed, k1=xa.size)
    return subtract_angle_part(rec, discrete, spr)
