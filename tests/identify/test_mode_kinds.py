"""Modes, order lines and noise poles told apart: each criterion against a closed form or
an independent simulation (scipy), and on records with known modes and lines."""

from __future__ import annotations

import re

import numpy as np
import pytest
import xarray as xr
from scipy import signal, stats

from gbpipe.config import load, merge
from gbpipe.errors import DataError
from gbpipe.identify import band_kurtosis, modes_table_rows, record_kinds, record_modes
from gbpipe.identify.band_kurtosis import kurtosis_limit, kurtosis_statistic
from gbpipe.identify.band_signal import band_envelope, band_spectrum, line_share
from gbpipe.identify.harmonic_lines import (
    HarmonicBands,
    harmonic_bands,
    order_one,
    speed_frequency_range,
)
from gbpipe.identify.mode_kinds import (
    ALPHA,
    LINE_SHARE,
    cluster_evidence,
    resolvable_damping,
)
from gbpipe.identify.peak_drift import peak_drift
from tests.conftest import CONFIG
from tests.identify.sdof import sdof_response

FS = 1000.0
NO_LINES = HarmonicBands(np.array([]), np.array([]), np.array([]), (np.nan, np.nan))


def _sdof(f0: float, zeta: float, n: int, rng: np.random.Generator) -> np.ndarray:
    return sdof_response(f0, zeta, n, rng, FS)


def _rippling_shaft(n: int) -> tuple[np.ndarray, np.ndarray]:
    # a 20 Hz shaft whose speed ripples 0.1 % over 20 s: its frequency [Hz] and angle [rad]
    shaft = 20.0 * (1 + 0.001 * np.sin(2 * np.pi * 0.05 * np.arange(n) / FS))
    return shaft, 2 * np.pi * np.cumsum(shaft) / FS


def test_band_kurtosis_of_a_sine_in_noise_is_the_closed_form():
    # x = A sin + Gaussian noise n: kurtosis 3 - 1.5 p^2, p the sine's share of the band
    # power (E s^4 = 3 A^4 / 8, E s^2 = A^2 / 2); the noise's band power measured alone
    rng = np.random.default_rng(1)
    t = np.arange(int(120 * FS)) / FS
    noise = rng.standard_normal(t.size)
    for amp in (0.05, 0.1, 0.3):
        x = amp * np.sin(2 * np.pi * 37.0 * t + 0.4) + noise
        z, _ = band_envelope(x, FS, 37.0, 1.0)
        zn, _ = band_envelope(noise, FS, 37.0, 1.0)
        # the real band signal is 2 Re z: its power 2 E|z|^2
        p = (amp ** 2 / 2) / (amp ** 2 / 2 + 2 * np.mean(np.abs(zn) ** 2))
        assert float(kurtosis_statistic(z)) == pytest.approx(3 - 1.5 * p ** 2, abs=0.12)
    # and it is the kurtosis of the real band signal (scipy.stats, on scipy's band-pass)
    sos = signal.butter(4, [36.0, 38.0], "bandpass", fs=FS, output="sos")
    xb = signal.sosfiltfilt(sos, 0.1 * np.sin(2 * np.pi * 37.0 * t) + noise)[5000:-5000]
    z, _ = band_envelope(0.1 * np.sin(2 * np.pi * 37.0 * t) + noise, FS, 37.0, 1.0)
    assert float(kurtosis_statistic(z)) == pytest.approx(stats.kurtosis(xb, fisher=False),
                                                         abs=0.1)


@pytest.mark.parametrize("amp", [0.0, 0.6, 1.5, 6.0])
def test_line_share_is_the_lines_power_over_the_bands(amp):
    # a mode's random response r plus an angle-locked line of amplitude a drifting 1 %
    # through its band: the line's power (a / 2)^2 in the band signal's convention. The
    # band's power is integrated from scipy's Welch PSD of the sum through the band
    # filter's gain (order-4 Butterworth low-pass, forward and backward:
    # 1 / (1 + (df / w)^8)^2). Per 2 s segment r projects on the line with power
    # s2 = S_r / (2 T_s) (S_r r's one-sided PSD there); over B segments the line's
    # power is then known to sqrt((2 (a/2)^2 s2 + s2^2) / B) (the floor's own error
    # taken as a quarter of the last term)
    rng = np.random.default_rng(4)
    t = np.arange(int(200 * FS)) / FS
    f_shaft = 12.0 * (1 + 0.01 * t / t[-1])
    angle = 2 * np.pi * np.cumsum(f_shaft) / FS
    r = _sdof(60.0, 0.02, t.size, rng)
    x = r / r.std() + amp * np.cos(5 * angle + 1.0)
    f, pxx = signal.welch(x, FS, nperseg=int(20 * FS))
    gain = 1 / (1 + ((f - 60.6) / 3.0) ** 8) ** 2
    band_power = np.sum(pxx * gain) * (f[1] - f[0]) / 2  # of the complex band signal
    fr, pr = signal.welch(r / r.std(), FS, nperseg=int(20 * FS))
    seg = 2.0
    s2 = np.mean(np.interp([60.0, 60.3, 60.6], fr, pr)) / (2 * seg)
    b = int(t[-1] / seg)
    sd = np.sqrt((2 * (amp / 2) ** 2 * s2 + 1.25 * s2 ** 2) / b)
    got = line_share(x - x.mean(), FS, angle, [5.0], seg, band_power, 3.0)
    assert abs(got.share * band_power - (amp / 2) ** 2) <= 4 * sd
    assert got.bound * band_power >= (amp / 2) ** 2  # the bound bounds
    # the angle is what tells the line: off by a shaft order, only the floor is left
    off = line_share(x - x.mean(), FS, angle, [4.0], seg, band_power, 3.0)
    assert off.share * band_power <= 4 * np.sqrt(1.25 * s2 ** 2 / b)
    # an order rounded off by 2e-4 turns the line 3 rad over the record, 0.03 rad in a
    # segment: the segments still hold it
    near = line_share(x - x.mean(), FS, angle, [5.0002], seg, band_power, 3.0)
    assert near.share * band_power == pytest.approx(got.share * band_power,
                                                    rel=0.01, abs=4 * sd)
    # two orders whose bands overlap: their powers add (the absent one's estimate
    # scatters about 0 by the floor's error)
    both = line_share(x - x.mean(), FS, angle, [5.0, 4.0], seg, band_power, 3.0)
    assert both.share * band_power == pytest.approx(got.share * band_power,
                                                    abs=4 * np.sqrt(1.25 * s2 ** 2 / b))


@pytest.mark.parametrize(("f0", "zeta"), [(24.0, 0.01), (150.0, 0.03)])
def test_kurtosis_limit_holds_for_modes_and_not_for_lines(f0, zeta):
    """The limit (drawn by FFT-shaped noise) against modes scipy simulates: no mode of 40
    falls below it (ALPHA = 0.1 % each), and a line 10 dB over the noise floor in the
    band does."""
    rng = np.random.default_rng(2)
    n = int(40 * FS)
    w = max(1.0, 2 * zeta * f0)
    k_modes = []
    for _ in range(40):
        y = _sdof(f0, zeta, n, rng)
        z, fs_z = band_envelope(y + 0.1 * y.std() * rng.standard_normal(n), FS, f0, w)
        k_modes.append(float(kurtosis_statistic(z)))
    limit = kurtosis_limit(f0, zeta, w, fs_z, z.size, ALPHA, np.random.default_rng(0))
    assert 1.5 < limit < 3.0
    assert min(k_modes) > limit, (min(k_modes), limit)
    assert abs(np.mean(k_modes) - 3.0) < 0.15  # a mode's band response is Gaussian
    t = np.arange(n) / FS
    zn, _ = band_envelope(y, FS, f0, w)
    amp = np.sqrt(2 * 10 * 2 * np.mean(np.abs(zn) ** 2))  # A^2 / 2 = 10x the band's
    z, _ = band_envelope(y + amp * np.sin(2 * np.pi * f0 * t), FS, f0, w)
    assert float(kurtosis_statistic(z)) < limit


def test_a_line_sweeping_through_the_band_drifts_a_mode_does_not():
    """A line whose shaft speeds up 1 % (254 -> 256.5 Hz, through a 1 Hz band: its PDF
    there is bursty, not a sinusoid's) has a monotonic peak track; the peaks of modes
    scipy simulates have none (p above ALPHA in each of 20 records)."""
    rng = np.random.default_rng(6)
    n = int(40 * FS)
    t = np.arange(n) / FS
    f_line = 254.0 * (1 + 0.01 * t / t[-1])
    x = np.sin(2 * np.pi * np.cumsum(f_line) / FS) + 0.3 * rng.standard_normal(n)
    d = peak_drift(x, FS, 255.2, 1.0, 2.0)
    assert d.n == 20 and d.rho > 0.9 and d.p < ALPHA, d
    assert d.gap_hz <= 0.5 + d.step_hz  # the track passes the pole
    z, _ = band_envelope(x, FS, 255.2, 0.5)
    assert float(kurtosis_statistic(z)) > 2.5  # the PDF test alone would not see it
    for _ in range(20):
        y = _sdof(111.0, 0.005, n, rng)
        assert peak_drift(y, FS, 111.0, 1.11, 2.0).p > ALPHA


def test_a_track_that_jumps_between_two_lines_beside_the_pole_is_no_drift():
    """A 7.8 % mode at 117 Hz (scipy) whose band (98.7-135.3 Hz) holds two steady lines,
    at 103 and 129 Hz: the first fades out over the record as the second grows (each 10
    times the mode's band power at its strongest). The band's peak moves from the first
    line to the second, a rank correlation with time near 1, but it never comes near the
    pole: no drift of the pole's, and the cluster is the mode the record holds."""
    rng = np.random.default_rng(31)
    n = int(40 * FS)
    t = np.arange(n) / FS
    f0, zeta = 117.0, 0.078
    mode = _sdof(f0, zeta, n, rng)
    amp = 2 * np.sqrt(10 * np.mean(np.abs(band_envelope(mode, FS, f0, 2 * zeta * f0)[0])
                                  ** 2))
    fade = t / t[-1]
    y = (mode + amp * (1 - fade) * np.sin(2 * np.pi * 103.0 * t)
         + amp * fade * np.sin(2 * np.pi * 129.0 * t + 1.0))
    d = peak_drift(y, FS, f0, 2 * zeta * f0, 2.0)
    assert d.rho > 0.8 and d.p < ALPHA and d.low_hz < f0 < d.high_hz, d
    assert d.gap_hz > 10.0, d  # both lines are over 10 Hz from the pole
    f = np.linspace(0, FS / 2, 1001)
    ev = cluster_evidence(f0, zeta, [y], ["y"], FS, f, np.ones_like(f), 0.5, 0.6, NO_LINES,
                          np.random.default_rng(0))
    assert ev.kind == "mode" and not ev.drifts, ev.text
    assert "does not pass the cluster" in ev.text, ev.text
    # 80 s whose 2 s segments switch between the lines: the first line alone for 9, the
    # two in turn for 22, the second alone for 9. Over half the steps are jumps of 26 Hz,
    # so their median size would pass the pole; their signed median is 0
    n2 = int(80 * FS)
    t2 = np.arange(n2) / FS
    k = np.arange(40)
    second = ((k % 2 == 1) & (k > 8)) | (k > 30)
    gate = np.repeat(second, int(2 * FS)).astype(float)
    y = (_sdof(f0, zeta, n2, rng) + amp * (1 - gate) * np.sin(2 * np.pi * 103.0 * t2)
         + amp * gate * np.sin(2 * np.pi * 129.0 * t2 + 1.0))
    d = peak_drift(y, FS, f0, 2 * zeta * f0, 2.0)
    assert np.mean(np.diff(second) != 0) > 0.5 and d.p < ALPHA, d
    assert d.gap_hz > 0.5 + d.step_hz, d
    ev = cluster_evidence(f0, zeta, [y], ["y"], FS, f, np.ones_like(f), 0.5, 0.6, NO_LINES,
                          np.random.default_rng(0))
    assert ev.kind == "mode" and not ev.drifts, ev.text


def _swept(t: np.ndarray, f_start: float, rise: float, amp: float) -> np.ndarray:
    # a line whose shaft speeds up linearly by `rise` (a fraction) over the record
    return amp * np.sin(2 * np.pi * np.cumsum(f_start * (1 + rise * t / t[-1])) / FS)


def test_a_swept_line_in_an_incoherent_band_of_a_two_mode_response_is_harmonic():
    """Two modes (180 Hz, 2 %; 250 Hz, 0.4 %) driven by white noise, a line sweeping 1 %
    (300 -> 303 Hz) through a band the input does not reach (coherence 0.1), another
    sweeping 0.8 % beside the 250 Hz mode (251.5 -> 253.5 Hz). The fit's pole on the
    first line (301 Hz, damping 0.0002: narrower than a frequency line) is harmonic by
    its drift although the line leaves the pole's own band for half the record; the
    modes stay modes."""
    rng = np.random.default_rng(11)
    n = int(40 * FS)
    t = np.arange(n) / FS
    y = _sdof(180.0, 0.02, n, rng) + 0.5 * _sdof(250.0, 0.004, n, rng)
    amp = 0.1 * y.std()
    x = (y + _swept(t, 300.0, 0.01, amp) + _swept(t, 251.5, 0.008, amp)
         + 0.01 * y.std() * rng.standard_normal(n))
    f = np.linspace(0, 500, 1001)
    coh = np.where(np.abs(f - 300.0) < 10, 0.1, 0.95)
    ev = cluster_evidence(301.0, 0.0002, [x], ["y"], FS, f, coh, 0.5, 0.6, NO_LINES, rng)
    assert ev.kind == "harmonic" and "drifts" in ev.text, ev.text
    # in the pole's own band (one frequency line each side) the track is flat at the
    # band's edge while the line is out of it: the drift is not significant there
    assert peak_drift(x, FS, 301.0, 0.5, 2.0).p > ALPHA
    for f0, zeta in ((250.0, 0.004), (180.0, 0.02)):
        ev = cluster_evidence(f0, zeta, [x], ["y"], FS, f, coh, 0.5, 0.6, NO_LINES, rng)
        assert ev.kind == "mode", ev.text


def test_the_widened_drift_band_calls_no_unresolved_mode_a_line():
    """A mode narrower than a frequency line (40 Hz, 0.5 %: 2 zeta f = 0.4 Hz < 0.5 Hz),
    its track searched over the Hann main lobe (+-1.5 Hz), in 20 records scipy simulates:
    p above ALPHA in each, and never harmonic."""
    rng = np.random.default_rng(12)
    n = int(40 * FS)
    f = np.linspace(0, 500, 1001)
    for _ in range(20):
        y = _sdof(40.0, 0.005, n, rng)
        y = y + 0.05 * y.std() * rng.standard_normal(n)
        assert peak_drift(y, FS, 40.0, 1.5, 2.0).p > ALPHA
        ev = cluster_evidence(40.0, 0.005, [y], ["y"], FS, f, np.ones_like(f), 0.5, 0.6,
                              NO_LINES, rng)
        assert ev.kind == "mode", ev.text


def test_a_pole_wider_than_the_line_on_it_is_the_mode_the_line_crosses():
    """A mode scipy simulates (200 Hz, 2.5 %: half-power band 10 Hz) under order 10 of a
    20 Hz shaft whose speed ripples 0.1 % (the line's band: 10 x 0.04 Hz plus one
    frequency line each side, 1.4 Hz), the line's amplitude 3 times the mode's rms: the
    band's power and PDF are the line's. The mode's pole (the truth) is the mode the line
    crosses; a pole as narrow as the line's band is the line; so is the wide pole where
    the speed is not measured (no angle: the band's width is then not the line's) or
    where the band is not coherent."""
    rng = np.random.default_rng(21)
    n = int(40 * FS)
    shaft, angle = _rippling_shaft(n)
    r = _sdof(200.0, 0.025, n, rng)
    x = r / r.std() + 3.0 * np.cos(10 * angle)
    bands = harmonic_bands((shaft.min(), shaft.max()), [10.0], 0.5, 0)
    width = float(bands.high_hz[0] - bands.low_hz[0])
    assert width == pytest.approx(1.4, abs=0.01)
    f = np.linspace(0, 500, 1001)
    coh = np.ones_like(f)

    def kind(zeta, coherence=coh, phase=angle):
        return cluster_evidence(200.0, zeta, [x], ["y"], FS, f, coherence, 0.5, 0.6, bands,
                                rng, phase)

    ev = kind(0.025)
    assert ev.kind == "mode" and "wider than any peak" in ev.text, ev.text
    share = float(re.search(r"has ([0-9.]+) times the power", ev.text).group(1))
    assert share > LINE_SHARE and ev.kurtosis < ev.kurtosis_limit  # the line's band
    ev = kind(0.9 * width / (2 * 200.0))
    assert ev.kind == "harmonic" and ev.text.startswith("order 10"), ev.text
    assert kind(0.025, phase=None).kind == "harmonic"
    assert kind(0.025, coherence=np.full_like(f, 0.3)).kind == "harmonic"


def test_a_subspace_pole_on_a_line_the_frfs_diagram_does_not_hold_is_the_line():
    """The record holds one mode (72 Hz, 2 %, scipy) and order 5 of a 20 Hz shaft at
    100 Hz with a third of the rms of the white noise in a 1.6 Hz band about it: the line
    holds a small share of the band, and the band is Gaussian. A subspace cluster at
    100 Hz (the fit of the whole output can give the line a pole) then reads as the
    mode the line crosses: by the line's share (0.4 %, narrower than the line's 1.2 Hz
    band) or by its width (1 %, 2 Hz wider). With the FRF diagram's clusters beside it,
    which hold only the 72 Hz mode, it is the line: the truth, for no mode lies at
    100 Hz. Where the FRF's diagram holds a cluster in its band, it is the mode again."""
    rng = np.random.default_rng(29)
    n = int(40 * FS)
    shaft, angle = _rippling_shaft(n)
    mode = _sdof(72.0, 0.02, n, rng)
    # the line's amplitude: a third of the white noise's rms in 1.6 Hz (1.6/500 of it)
    amp = np.sqrt(2 * 1.6 / (FS / 2)) / 3
    x = 0.5 * mode / mode.std() + rng.standard_normal(n) + amp * np.cos(5 * angle)
    bands = harmonic_bands((shaft.min(), shaft.max()), [5.0], 0.5, 0)._replace(
        source="the tacho")
    assert float(bands.high_hz[0] - bands.low_hz[0]) == pytest.approx(1.2, abs=0.01)
    f = np.linspace(0, 500, 1001)
    coh = np.ones_like(f)
    for zeta, w in ((0.004, 0.8), (0.01, 2.0)):  # w: the cluster's band, max(0.5, 2 zeta f)

        def judge(frf_hz, zeta=zeta):  # the same Monte Carlo draws for every frf_hz
            return cluster_evidence(100.0, zeta, [x], ["y"], FS, f, coh, 0.5, 0.6, bands,
                                    np.random.default_rng(7), angle, frf_hz)

        alone = judge(None)
        assert alone.kind == "mode" and "5 of the tacho cross" in alone.text, alone.text
        bound = float(re.search(r"at most ([0-9.]+) with", alone.text).group(1))
        assert bound < LINE_SHARE and alone.kurtosis >= alone.kurtosis_limit, alone.text
        beside = judge(np.array([71.9, 100.0 + 1.1 * w]))
        assert beside.kind == "harmonic" and beside.text.startswith("order 5"), beside.text
        assert (f"the FRF's diagram (LSCF) holds no pole in {100 - w:.1f}-{100 + w:.1f} Hz"
                in beside.text), beside.text
        assert judge(np.array([71.9, 100.0 + 0.9 * w])).kind == "mode"


def test_damping_below_the_records_resolution_is_a_line():
    assert resolvable_damping(50.0, 40.0) == pytest.approx(1 / (2 * 50 * 40))
    rng = np.random.default_rng(3)
    y = _sdof(50.0, 0.02, int(40 * FS), rng)[:, None]
    f = np.linspace(0, 500, 501)
    ev = cluster_evidence(50.0, 0.2 * resolvable_damping(50.0, 40.0), [y[:, 0]], ["y"], FS,
                          f, np.ones_like(f), 1.0, 0.6, NO_LINES, rng)
    assert ev.kind == "harmonic" and "resolution" in ev.text
    ev = cluster_evidence(50.0, 0.02, [y[:, 0]], ["y"], FS, f, np.ones_like(f), 1.0, 0.6,
                          NO_LINES, rng)
    assert ev.kind == "mode", ev.text


def test_a_pole_where_nothing_is_coherent_is_spurious():
    rng = np.random.default_rng(4)
    y = _sdof(80.0, 0.02, int(40 * FS), rng)
    f = np.linspace(0, 500, 1001)
    coh = np.where(np.abs(f - 80.0) < 5, 0.3, 0.95)  # incoherent around the pole only
    ev = cluster_evidence(80.0, 0.02, [y], ["y"], FS, f, coh, 0.5, 0.6, NO_LINES, rng)
    assert ev.kind == "spurious" and "coherence 0.30" in ev.text
    ev = cluster_evidence(80.0, 0.02, [y], ["y"], FS, f, coh, 0.5, 0.25, NO_LINES, rng)
    assert ev.kind == "mode"


def test_speed_signal_gives_the_reference_shafts_range():
    # a shaft at twice the reference speed, sweeping 20 -> 22 Hz (reference 10 -> 11 Hz),
    # with encoder noise: averaged over 1 s segments, the ends are the segment means of
    # the linear sweep, 10 + 0.5 / 60 and 11 - 0.5 / 60 Hz
    t = np.arange(int(60 * FS)) / FS
    speed = 2 * np.pi * (20.0 + 2.0 * t / t[-1])
    noisy = speed + 5.0 * np.random.default_rng(5).standard_normal(t.size)
    lo, hi = speed_frequency_range(noisy, FS, 2.0, 1.0)
    assert lo == pytest.approx(10.0 + 0.5 / 60, abs=0.02)
    assert hi == pytest.approx(11.0 - 0.5 / 60, abs=0.02)
    with pytest.raises(DataError, match="reverses"):
        speed_frequency_range(np.sin(2 * np.pi * 0.05 * t), FS, 1.0, 1.0)


def test_order_one_is_the_line_whose_multiples_hold_the_others():
    lines = np.array([53.6, 53.8, 107.5, 71.7, 161.2])
    b = order_one(lines, [4 / 3], 0.5, 3, 400.0)
    assert b.shaft_hz == (53.6, 53.8)
    assert b.order.tolist() == [1.0, 4 / 3, 2.0, 3.0]
    for f in lines:  # every line is on one of its orders
        assert np.any((b.low_hz <= f) & (f <= b.high_hz))
    assert "53.60 Hz" in b.source
    # a speed signal of the shaft (no shaft_order) that holds as many lines is preferred
    # (a measured range); one that holds none is not taken
    b = order_one(lines, [4 / 3], 0.5, 3, 400.0, {"enc": (53.55, 53.85)})
    assert b.shaft_hz == (53.55, 53.85) and "enc" in b.source
    b = order_one(lines, [], 0.5, 3, 400.0, {"enc": (12.0, 12.1)})
    assert "enc" not in b.source
    assert order_one(np.array([]), [], 0.5, 3).order.size == 0


def test_a_mode_whose_band_holds_a_line_of_the_records_own_family_is_a_mode():
    """No speed measured: the lines at orders 1, 2 and 7 of a 10.386 Hz shaft, and a 5 %
    mode at 72 Hz whose band holds the order-7 line at 72.7 Hz, within two frequency
    lines of the pole but off its own band (72.2-73.2 Hz), with ten times the mode's power
    there. Judged alone, the line makes the mode's band a sinusoid's, and the pole's;
    once the record's own order-1 line places order 7 in it, the cluster, whose
    half-power band (7.2 Hz) no line of the family can make, is judged as with a measured
    speed: the mode."""
    rng = np.random.default_rng(12)
    n = int(40 * FS)
    t = np.arange(n) / FS
    mode = _sdof(72.0, 0.05, n, rng)
    z, _ = band_envelope(mode, FS, 72.0, 7.2)
    band = np.mean(np.abs(z) ** 2)  # the mode's band power (a sinusoid a: a^2 / 4)
    shaft = 72.7 / 7
    y = mode + sum(2 * np.sqrt(10 * band) * np.sin(2 * np.pi * shaft * k * t + k)
                   for k in (1, 2, 7))
    y = y + 0.01 * y.std() * rng.standard_normal(n)
    f = np.linspace(0, FS / 2, 1001)
    data = [record_kinds.PairingData(y[:, None], ["y"], FS, f, np.ones_like(f))]
    clusters = [record_kinds.Cluster(0, fk, 1e-4) for fk in (shaft, 2 * shaft, 72.7)]
    clusters.append(record_kinds.Cluster(0, 72.0, 0.05))
    alone = cluster_evidence(72.0, 0.05, [y], ["y"], FS, f, np.ones_like(f), 0.5, 0.6,
                             NO_LINES, np.random.default_rng(0))
    assert alone.kind == "harmonic" and "sinusoid" in alone.text  # the line holds it
    ev, own = record_kinds.record_evidence(clusters, data, NO_LINES, [7.0], 0.5, 0.6, 2,
                                         400.0, 0)
    assert own.shaft_hz[0] == pytest.approx(shaft, abs=0.01) and 7.0 in own.order
    assert [e.kind for e in ev] == ["harmonic"] * 3 + ["mode"], [e.text for e in ev]
    assert "the line in its band sets its PDF" in ev[3].text
    assert "order line(s) 7: the PDF test does not decide" in ev[3].text


def test_band_spectrum_holds_a_steady_line_and_a_swept_one_where_they_are():
    """The band signal's PSD about the band's centre, its strongest peak from edge to edge
    at half power, against closed forms: a steady line spans the Hann window's
    half-power width, 1.44 frequency lines, about its frequency; a line swept linearly
    over 3 Hz spans its sweep (the segments' average of a linear chirp is the window's
    power kernel swept over a flat density: by symmetry half its plateau at the sweep's
    ends). Both 20 dB over white noise in a 10 Hz band, 2 s segments (0.5 Hz); and the
    PSD integrates to the band signal's power (Parseval)."""
    rng = np.random.default_rng(21)
    t = np.arange(int(60 * FS)) / FS
    noise = rng.standard_normal(t.size)
    steady = np.sin(2 * np.pi * 102.3 * t)
    swept = signal.chirp(t, 98.5, t[-1], 101.5)
    for line, lo, hi in ((steady, 2.3 - 0.72 / 2, 2.3 + 0.72 / 2), (swept, -1.5, 1.5)):
        power = np.mean(line ** 2)
        x = line + np.sqrt(power / 100 * FS / 20) * noise  # 20 dB over the noise in 10 Hz
        z, fs_z = band_envelope(x, FS, 100.0, 10.0)
        offset, psd = band_spectrum(z, fs_z, 2.0)
        assert np.all(np.diff(offset) > 0)
        assert np.sum(psd) * (offset[1] - offset[0]) == pytest.approx(
            np.mean(np.abs(z) ** 2), rel=0.05)
        top = int(np.argmax(psd))
        below = np.flatnonzero(psd < 0.5 * psd[top])
        low = offset[below[below < top].max() + 1]
        high = offset[below[below > top].min() - 1]
        # edges on the 4x zero-padded grid (0.125 Hz): half a grid step each side
        assert low == pytest.approx(lo, abs=0.2), (low, high)
        assert high == pytest.approx(hi, abs=0.2), (low, high)


CASES = np.random.default_rng(22)
#: Random modes (80-250 Hz, damping 2-6 %) with a line in the outer half of their band,
#: 1.45-1.85 half-power half-widths off, and 10 dB over the mode's power in the band.
BESIDE = [(CASES.uniform(80, 250), CASES.uniform(0.02, 0.06), CASES.uniform(1.45, 1.85)
           * CASES.choice([-1, 1]), seed) for seed in range(4)]


@pytest.mark.parametrize(("f0", "zeta", "offset", "seed"), BESIDE)
def test_a_line_beside_the_pole_in_its_band_is_not_the_poles_sinusoid(f0, zeta, offset,
                                                                       seed):
    """A mode of ``f0``, ``zeta`` (scipy) and a steady line ``offset`` half-power
    half-widths ``zeta f0`` from it, inside the cluster's band (twice the half-power
    band), with ten times the mode's band power: the band reads as a sinusoid (closed
    form: kurtosis 3 - 1.5 (10 / 11)^2 = 1.76), but the sinusoid is the line's, beside
    the pole. No speed is measured: the cluster is the mode the record holds. So it is
    with the line 1.5 Hz off (inside the pole's half-power band, 1.6 Hz and more, but
    three frequency lines off); 0.2 Hz off, within a frequency line, the line is the
    pole's sinusoid: a line."""
    rng = np.random.default_rng(seed)
    n = int(40 * FS)
    t = np.arange(n) / FS
    mode = _sdof(f0, zeta, n, rng)
    w = 2 * zeta * f0
    z, _ = band_envelope(mode, FS, f0, w)
    amp = 2 * np.sqrt(10 * np.mean(np.abs(z) ** 2))
    f = np.linspace(0, FS / 2, 1001)
    side = np.sign(offset)
    for at, kind in ((offset * zeta * f0, "mode"), (side * 1.5, "mode"), (side * 0.2,
                                                                          "harmonic")):
        y = mode + amp * np.sin(2 * np.pi * (f0 + at) * t + 0.5)
        ev = cluster_evidence(f0, zeta, [y], ["y"], FS, f, np.ones_like(f), 0.5, 0.6,
                              NO_LINES, np.random.default_rng(seed))
        assert ev.kurtosis < ev.kurtosis_limit and abs(ev.kurtosis - 1.76) < 0.3, ev.text
        assert ev.kind == kind and ev.sinusoid == (kind == "harmonic"), ev.text
        assert ("a peak beside the pole" in ev.text) == (kind == "mode")


def test_the_sinusoid_reported_is_the_poles_where_one_output_has_it():
    """Two outputs of one mode (120 Hz, 3 %, scipy): the first holds a line beside the
    pole (1.7 half-widths off, 30 times the mode's band power), the second one at the pole
    (0.1 of a half-width off, 10 times). The pole's sinusoid is the second's: `harmonic`,
    with the second's reading, and no fact says the test does not decide. With the
    second's line moved beside the pole too, the cluster is the mode the record holds.
    And a line at the pole keeps its reading beside a stronger line (twice its power)
    in the same output: the spectrum in the pole's band reaches half the strongest peak."""
    f0, zeta, seed = 120.0, 0.03, 5
    rng = np.random.default_rng(seed)
    n = int(40 * FS)
    t = np.arange(n) / FS
    modes = [_sdof(f0, zeta, n, rng) for _ in range(2)]
    w = 2 * zeta * f0
    own = [np.mean(np.abs(band_envelope(m, FS, f0, w)[0]) ** 2) for m in modes]

    def line(k: int, at: float, times: float) -> np.ndarray:
        return 2 * np.sqrt(times * own[k]) * np.sin(2 * np.pi * (f0 + at * zeta * f0) * t)

    f = np.linspace(0, FS / 2, 1001)
    beside = modes[0] + line(0, 1.7, 30)
    for second, kind in ((line(1, 0.1, 10), "harmonic"), (line(1, -1.7, 30), "mode")):
        ev = cluster_evidence(f0, zeta, [beside, modes[1] + second], ["a", "b"], FS, f,
                              np.ones_like(f), 0.5, 0.6, NO_LINES,
                              np.random.default_rng(seed))
        assert ev.kind == kind and ev.kurtosis < ev.kurtosis_limit, ev.text
        if kind == "harmonic":  # b's reading, and no word of a's line
            assert "of b (sinusoid" in ev.text and "a's spectrum" not in ev.text, ev.text
        else:
            assert "a's spectrum" in ev.text and "b's spectrum" in ev.text, ev.text
    both = modes[0] + line(0, 1.7, 20) + line(0, 0.1, 10)
    ev = cluster_evidence(f0, zeta, [both], ["a"], FS, f, np.ones_like(f), 0.5, 0.6,
                          NO_LINES, np.random.default_rng(seed))
    assert ev.kind == "harmonic" and ev.sinusoid, ev.text


# -- records with one known mode and known lines, with a tacho, a speed signal, or none --

F0, ZETA, SHAFT = 40.0, 0.02, (10.95, 11.05)  # Hz, -, Hz (the shaft's slow drift)
LINE_ORDERS = (1.0, 2.0, 7.0)  # unbalance, misalignment, a mesh of 7 teeth


#: A mesh order whose line sweeps through the mode (F0 over the mean shaft frequency).
CROSSING = F0 / np.mean(SHAFT)


def _lines_record(speed: str, seed: int = 8, crossing: float = 0.0) -> xr.Dataset:
    """A torsional oscillator (J = 0.5 kg m^2) under a white motor torque plus the
    angle-locked torques of a shaft drifting over ``SHAFT``; the output is its speed with
    2 % noise. ``speed``: ``tacho`` (1 pulse per rev), ``speed`` (a speed signal of a
    shaft at twice the reference) or ``none``. ``crossing``: amplitude [N m] of a further
    line of order ``CROSSING``, through the mode."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(40 * FS)) / FS
    f_shaft = SHAFT[0] + (SHAFT[1] - SHAFT[0]) * t / t[-1]
    theta = 2 * np.pi * np.cumsum(f_shaft) / FS
    u = 50.0 * rng.standard_normal(t.size)
    lines = sum(a * np.sin(k * theta + rng.uniform(0, 6)) for k, a in
                zip(LINE_ORDERS, (400.0, 300.0, 400.0), strict=True))
    lines = lines + crossing * np.sin(CROSSING * theta + 0.7)
    wn = 2 * np.pi * F0
    sysd = signal.cont2discrete((np.array([[0, 1], [-wn ** 2, -2 * ZETA * wn]]),
                                 np.array([[0], [2.0]]), np.array([[0, 1.0]]),
                                 np.zeros((1, 1))), 1 / FS)
    _, y, _ = signal.dlsim(sysd[:4] + (1 / FS,), u + lines, t)
    y = y[:, 0] + 0.02 * y.std() * rng.standard_normal(t.size)
    attrs = {"units": "N m", "long_name": "torque"}
    data = {"torque": ("time", u + 0.3 * lines, attrs),
            "speed": ("time", y, {"units": "rad/s", "long_name": "speed"})}
    if speed == "speed":
        data["shaft2"] = ("time", 2 * 2 * np.pi * f_shaft + rng.standard_normal(t.size),
                          {"units": "rad/s", "long_name": "speed of the shaft at 2x"})
    out = xr.Dataset(data, coords={"time": ("time", t, {"units": "s", "long_name": "time"})},
                     attrs={"sample_rate": FS, "record": "lines", "record_kind": "measured"})
    if speed == "tacho":
        pulses = np.interp(np.arange(1, int(theta[-1] / (2 * np.pi))) * 2 * np.pi, theta, t)
        out["pulse_time"] = ("pulse", pulses, {"units": "s", "long_name": "pulse time"})
        out.attrs["pulses_per_rev"] = 1
    return out


@pytest.mark.parametrize("speed", ["tacho", "speed", "none"])
def test_kinds_of_a_record_with_known_mode_and_lines(speed):
    cfg = merge(load(CONFIG), {"campaign": {"settle": 1.0}, "identify": {
        "versions": ["raw"], "pairings": [{"name": "T_w", "inputs": ["torque"],
                                           "outputs": ["speed"]}]}})
    rec = _lines_record(speed)
    ds = record_modes(cfg, rec, orders=[7.0], speeds={"shaft2": 2.0} if speed == "speed"
                      else None)
    res = 1.0 / cfg["identify"]["nonparametric"]["segment"]
    on_line = [(k * SHAFT[0] - res, k * SHAFT[1] + res) for k in (*LINE_ORDERS, 3.0)]
    rows = modes_table_rows(ds, "lines")
    assert rows
    found, n_lines = False, 0
    for r in rows:
        f = r["frequency_hz"]
        if any(lo <= f <= hi for lo, hi in on_line):
            assert r["kind"] == "harmonic", r
            n_lines += 1
        elif abs(f - F0) <= 0.01 * F0:
            assert r["kind"] == "mode", r
            found = True
        else:  # no other mode in the record: anything else is not a mode
            assert r["kind"] != "mode", r
    assert found and n_lines >= 2  # the lines do make stable clusters: the test bites
    # a subspace line the FRF's diagram does not hold says so (the LSCF diagram of the
    # same pairing); only with a measured speed, which places the lines before the PDF
    held_not = [r for r in rows if "the FRF's diagram (LSCF) holds no pole" in r["evidence"]]
    assert all(r["method"] == "pbsid" and r["kind"] == "harmonic" for r in held_not)
    assert bool(held_not) == (speed != "none"), rows
    for r in held_not:
        lo, hi = map(float, re.search(r"holds no pole in ([0-9.]+)-([0-9.]+) Hz",
                                      r["evidence"]).groups())
        assert not any(lo <= q["frequency_hz"] <= hi for q in rows if q["method"] == "lscf")
    # the model order holds the mode and the diagram's lines, and no lower order does
    tol = cfg["identify"]["stabilization"]["frequency_tolerance"]
    d = ds.sel({"method": "pbsid"}).isel(pairing=0)
    f = d.mode_frequency.values
    # its own lines: those its diagram at the identification rate found (not zoomed)
    need = f[(d.mode_kind.values == "mode") | ((d.mode_kind.values == "harmonic")
                                              & (d.mode_decimation.values == 1))]
    held = [all(np.nanmin(np.abs(p - fk), initial=np.inf) <= tol * fk for fk in need)
            for p in d.model_pole_frequency.values]  # the identification rate's diagram
    assert int(d.model_order) == int(d.order.values[held.index(True)])


@pytest.mark.parametrize("speed", ["tacho", "speed"])
def test_a_line_through_the_mode_is_the_mode_where_it_holds_little_of_the_band(speed):
    """A mesh line sweeping through the 40 Hz mode. Weak (its share of the mode's band,
    measured here from the record's own PSD, well under half), the cluster there is the
    mode the line crosses; strong (well over half), it is the line. Before the line's
    share was measured, both were ``harmonic``: one speed range cannot tell them."""
    cfg = merge(load(CONFIG), {"campaign": {"settle": 1.0}, "identify": {
        "versions": ["raw"], "pairings": [{"name": "T_w", "inputs": ["torque"],
                                           "outputs": ["speed"]}]}})
    res = 1.0 / cfg["identify"]["nonparametric"]["segment"]
    band = (CROSSING * SHAFT[0] - res, CROSSING * SHAFT[1] + res)
    for amp, kind in ((2.0, "mode"), (60.0, "harmonic")):
        rec = _lines_record(speed, crossing=amp)
        # the line's share of the mode's half-power band, from scipy's PSD of the output
        # and of the same record without the line
        base = _lines_record(speed, crossing=0.0)
        f, p_all = signal.welch(rec["speed"].values, FS, nperseg=int(4 * FS))
        _, p_base = signal.welch(base["speed"].values, FS, nperseg=int(4 * FS))
        near = np.abs(f - F0) <= 2 * ZETA * F0
        share = 1 - p_base[near].sum() / p_all[near].sum()
        assert (share < 0.25) if kind == "mode" else (share > 0.75)
        ds = record_modes(cfg, rec, orders=[CROSSING], speeds={"shaft2": 2.0}
                          if speed == "speed" else None)
        rows = [r for r in modes_table_rows(ds, "lines")
                if abs(r["frequency_hz"] - F0) <= 0.01 * F0]
        assert rows, "the diagrams hold a cluster at the mode"
        assert {r["kind"] for r in rows} == {kind}, rows
        # the line's measured share decided (not the PDF or drift test): its bound
        for r in rows:
            got = re.search(r"has ([0-9.]+) times the power in \S+ Hz \(at most ([0-9.]+)",
                            r["evidence"])
            assert got, r["evidence"]
            assert (float(got[2]) < 0.5) if kind == "mode" else (float(got[2]) >= 0.5)
            assert float(got[1]) == pytest.approx(share, abs=0.1 + 0.1 * share)
        if kind == "mode":
            assert all(f"order {CROSSING:.4g}" in r["evidence"] and "crosses" in r["evidence"]
                       for r in rows), rows
            assert all(band[0] <= r["frequency_hz"] <= band[1] for r in rows)


def test_lines_alone_set_no_model_order():
    """With the band ending below the 40 Hz mode, the diagrams hold only the order lines
    at 11 and 22 Hz: they are labelled and reported, but set no model order."""
    cfg = merge(load(CONFIG), {"campaign": {"settle": 1.0}, "identify": {
        "versions": ["raw"], "frf": {"f_max": 35.0},
        "pairings": [{"name": "T_w", "inputs": ["torque"], "outputs": ["speed"]}]}})
    ds = record_modes(cfg, _lines_record("tacho"))
    d = ds.sel({"method": "pbsid"}).isel(pairing=0)
    f = d.mode_frequency.values
    assert np.isfinite(f).sum() >= 1
    assert set(d.mode_kind.values[np.isfinite(f)]) == {"harmonic"}
    assert int(d.model_order) == 0 and str(d.status.values).startswith("no mode")


@pytest.mark.parametrize(("f0", "zeta", "w", "fs_z"),
                         [(150.0, 0.03, 9.0, 40.0), (24.0, 0.01, 1.0, 4.0),
                          (300.0, 0.05, 30.0, 130.0)])
def test_kurtosis_limit_of_a_long_band_from_shorter_draws(monkeypatch, f0, zeta, w, fs_z):
    # a band 8 times DRAWN_SAMPLES long (and many correlation times): the limit from draws
    # of DRAWN_SAMPLES, its log spread scaled by sqrt(1/8), is the one the whole band's
    # draws give, within a third of the log statistic's spread (each Monte Carlo limit
    # scatters by about 0.08 of it); unscaled, it would lie 5 spreads lower
    n = 16384
    whole = kurtosis_limit(f0, zeta, w, fs_z, n, ALPHA, np.random.default_rng(5))
    monkeypatch.setattr(band_kurtosis, "DRAWN_SAMPLES", n // 8)
    drawn = kurtosis_limit(f0, zeta, w, fs_z, n, ALPHA, np.random.default_rng(5))
    spread = (np.log(3.0) - np.log(whole)) / stats.norm.isf(ALPHA)  # (the mean: about 3)
    assert abs(np.log(drawn / whole)) < spread / 3, (drawn, whole, spread)
