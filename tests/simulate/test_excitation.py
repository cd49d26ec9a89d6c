"""Designed excitation signals: multisine and PRBS against independent computations
(the DFT of one period, the m-sequence autocorrelation), and the set-point limit check."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import periodogram

from gbpipe.errors import ExcitationError
from gbpipe.simulate import multisine, prbs, within_limits
from gbpipe.simulate.excitation import multisine_lines

FS = 1000.0  # Hz


def crest(x: np.ndarray) -> float:
    return float(np.max(np.abs(x)) / np.sqrt(np.mean(x ** 2)))


def test_multisine_lines_on_grid_and_nothing_outside():
    # period 0.5 s -> grid 2 Hz; record of 1.25 s holds 2.5 periods (last one cut short)
    x = multisine(FS, 1.25, 9.0, 41.0, 3.0, frequency_resolution=2.0)
    p = 500
    np.testing.assert_array_equal(x[p:2 * p], x[:p])
    np.testing.assert_array_equal(x[2 * p:], x[:x.size - 2 * p])
    mag = np.abs(np.fft.rfft(x[:p])) / p
    f = np.fft.rfftfreq(p, 1 / FS)
    inside = (f >= 9.0) & (f <= 41.0)
    np.testing.assert_array_equal(f[inside], np.arange(10.0, 42.0, 2.0))
    assert np.all(mag[inside] > 1e-3)
    assert np.max(mag[~inside]) < 1e-10 * np.max(mag)  # -200 dB: numerically zero
    assert np.sqrt(np.mean(x[:p] ** 2)) == pytest.approx(3.0, rel=1e-12)


def test_multisine_default_period_is_the_record():
    x = multisine(FS, 2.0, 1.0, 10.0, 0.7)
    mag = np.abs(np.fft.rfft(x)) / x.size
    lines = np.flatnonzero(mag > 1e-10 * mag.max())
    np.testing.assert_array_equal(lines, np.arange(2, 21))  # 1..10 Hz on a 0.5 Hz grid
    assert np.sqrt(np.mean(x ** 2)) == pytest.approx(0.7, rel=1e-12)


def test_schroeder_phases_give_low_crest_factor():
    # 200 lines, flat spectrum: Schroeder below 1.8, well below random phases
    kwargs = dict(fs=FS, duration=2.0, f_min=0.5, f_max=100.0, rms=1.0)
    schroeder = crest(multisine(**kwargs))
    random = crest(multisine(**kwargs, phases="random", seed=7))
    assert len(multisine_lines(**kwargs).bins) == 200
    assert schroeder < 1.8
    assert schroeder < random


def test_schroeder_phases_match_the_published_formula():
    # phi_k = phi_1 - 2 pi sum_{l<k} (k - l) p_l, written as the plain double sum
    shape = lambda f: 1.0 + f / 10.0  # noqa: E731
    lines = multisine_lines(FS, 1.0, 3.0, 30.0, 1.0, amplitude=shape)
    p = shape(lines.frequency) ** 2 / np.sum(shape(lines.frequency) ** 2)
    expected = [-2 * np.pi * sum((k - l) * p[l] for l in range(k)) for k in range(p.size)]
    np.testing.assert_allclose(np.exp(1j * lines.phase), np.exp(1j * np.array(expected)),
                               atol=1e-9)


def test_user_amplitude_spectrum_is_reproduced():
    shape = lambda f: np.exp(-f / 20.0)  # noqa: E731
    x = multisine(FS, 1.0, 5.0, 60.0, 2.0, amplitude=shape, phases="random", seed=3)
    amp = 2 * np.abs(np.fft.rfft(x)) / x.size
    f = np.fft.rfftfreq(x.size, 1 / FS)
    band = (f >= 5.0) & (f <= 60.0)
    ratio = amp[band] / shape(f[band])
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)
    assert np.sqrt(np.mean(x ** 2)) == pytest.approx(2.0, rel=1e-12)


def test_random_phases_are_reproducible_from_the_seed():
    a = multisine(FS, 1.0, 1.0, 50.0, 1.0, phases="random", seed=11)
    b = multisine(FS, 1.0, 1.0, 50.0, 1.0, phases="random", seed=11)
    c = multisine(FS, 1.0, 1.0, 50.0, 1.0, phases="random", seed=12)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


@pytest.mark.parametrize("seed", [None, 5])
def test_prbs_is_a_held_m_sequence(seed):
    fs, clock, amp = FS, 100.0, 250.0
    x = prbs(fs, 1.4, amp, clock_hz=clock, seed=seed)  # 140 bits -> nbits 7, 127 bits
    assert x.size == 1400
    assert set(np.unique(x)) == {-amp, amp}
    bits = x.reshape(-1, 10)
    assert np.all(bits == bits[:, :1])  # each bit held fs / clock_hz samples
    n = 2 ** 7 - 1
    seq = bits[:n, 0] / amp
    np.testing.assert_array_equal(bits[n:, 0], bits[:bits.shape[0] - n, 0])  # periodic
    # the defining property: circular autocorrelation N at lag 0, -1 at every other lag
    acf = np.array([seq @ np.roll(seq, lag) for lag in range(n)])
    assert acf[0] == n
    np.testing.assert_array_equal(acf[1:], -1.0)


def test_prbs_seed_changes_the_start_only():
    a = prbs(FS, 1.27, 1.0, clock_hz=FS)
    b = prbs(FS, 1.27, 1.0, clock_hz=FS, seed=2)
    assert a.size == b.size == 1270
    seq_a, seq_b = a[:1023], b[:1023]
    shifts = [k for k in range(1023) if np.array_equal(np.roll(seq_a, k), seq_b)]
    assert len(shifts) == 1  # the same m-sequence, another start


def test_within_limits_passes_inside_and_names_the_sample_outside():
    t = np.arange(1000) / FS
    ref = np.full(t.size, 30e3)  # N·m
    exc = 5e3 * np.sin(2 * np.pi * 2.0 * t)
    within_limits(ref, exc, 36e3, "torque_ref", fs=FS)
    with pytest.raises(ExcitationError) as err:
        within_limits(ref, exc, 34e3, "torque_ref", fs=FS)
    first = int(np.flatnonzero(ref + exc > 34e3)[0])
    msg = str(err.value)
    assert f"sample {first}" in msg and f"t = {first / FS:g} s" in msg
    assert "torque_ref" in msg and "factor <= 0.8" in msg  # (34 - 30) / 5 kN·m
    with pytest.raises(ExcitationError, match="reference alone"):
        within_limits(ref, exc, 29e3, "torque_ref")


@pytest.mark.parametrize("call, arg", [
    (lambda: multisine(FS, 1.0, 1.0, 600.0, 1.0), "f_max"),
    (lambda: multisine(FS, 1.0, 50.0, 50.0, 1.0), "f_min"),
    (lambda: multisine(FS, 1.0, 1.0, 50.0, 0.0), "rms"),
    (lambda: multisine(FS, 1.0, 1.0, 50.0, -1.0), "rms"),
    (lambda: multisine(FS, 1.0, 1.0, 50.0, 1.0, phases="random"), "seed"),
    (lambda: multisine(FS, 1.0, 1.0, 50.0, 1.0, phases="zero"), "phases"),
    (lambda: multisine(FS, 1.0, 1.0, 50.0, 1.0, frequency_resolution=0.5), "frequency_res"),
    (lambda: multisine(FS, 1.0, 1.2, 1.8, 1.0), "f_min, f_max"),
    (lambda: multisine(FS, 1.0, 1.0, 5.0, 1.0, amplitude=lambda f: -f), "amplitude"),
    (lambda: prbs(FS, 1.0, 1.0, clock_hz=300.0), "clock_hz"),
    (lambda: prbs(FS, 1.0, 1.0, clock_hz=2000.0), "clock_hz"),
    (lambda: prbs(FS, 1.0, 0.0, clock_hz=100.0), "amplitude"),
    (lambda: prbs(FS, 0.02, 1.0, clock_hz=100.0), "duration"),
    (lambda: within_limits(np.zeros(3), np.zeros(4), 1.0, "x"), "excitation"),
])
def test_bad_arguments_raise_value_error_naming_the_argument(call, arg):
    with pytest.raises(ValueError, match=f"^{arg}"):
        call()


def test_prbs_spectrum_is_flat_below_0_3_clock():
    fs, clock = FS, 100.0
    x = prbs(fs, 1.27, 1.0, clock_hz=clock, seed=1)  # exactly one period of 127 bits
    f, pxx = periodogram(x, fs, window="boxcar")
    band = (f > 0) & (f <= 0.3 * clock)
    db = 10 * np.log10(pxx[band] / pxx[band].max())
    assert db.min() > -1.4  # the sinc**2 envelope of the held bits: -1.32 dB at 0.3 clock
    assert pxx[0] < 1e-3 * pxx[band].max()  # an m-sequence has mean 1 / N: nearly no DC
