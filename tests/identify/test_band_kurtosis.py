"""The PDF test of one band where a strong order line lies just outside it: the line leaks
through the order-4 low-pass's skirt and makes a mode's band read as a sinusoid; the
steeper filters read the band itself. Checked against scipy's simulation of the mode, a
Welch PSD of it through the filter's gain, and the closed form of the skirt."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, signal

from gbpipe.identify.band_kurtosis import (
    CHECK_ORDERS,
    OWN_POWER,
    band_statistic,
    kurtosis_limit,
    kurtosis_statistic,
)
from gbpipe.identify.band_signal import FILTER_ORDER, band_envelope
from gbpipe.identify.harmonic_lines import HarmonicBands
from gbpipe.identify.mode_kinds import ALPHA, cluster_evidence
from tests.identify.sdof import sdof_response

FS = 1000.0
DURATION = 40.0
RESOLUTION = 0.5
NO_LINES = HarmonicBands(np.array([]), np.array([]), np.array([]), (np.nan, np.nan))


def _sdof(f0: float, zeta: float, n: int, rng: np.random.Generator) -> np.ndarray:
    return sdof_response(f0, zeta, n, rng, FS)


def _band_power(x: np.ndarray, f0: float, w: float, order: int) -> float:
    """Power of the complex band signal from scipy's Welch PSD of ``x`` through the
    low-pass's gain (forward and backward: 1 / (1 + (df / w)^(2 order))^2)."""
    f, pxx = signal.welch(x, FS, nperseg=int(8 * FS))
    gain = 1 / (1 + ((f - f0) / w) ** (2 * order)) ** 2
    return float(np.sum(pxx * gain) * (f[1] - f[0]) / 2)


def _cases(n: int) -> list[tuple[float, float, float, float]]:
    """Random modes (40-300 Hz, 1.5-6 %) with a line 1.6-2.5 band half-widths beside the
    band's centre (either side), 45-70 dB over the band's power (its leak through the
    order-4 skirt from 10 dB under the band's power to 25 dB over it)."""
    rng = np.random.default_rng(11)
    return [(float(rng.uniform(40, 300)), float(rng.uniform(0.015, 0.06)),
             float(rng.choice([-1, 1]) * rng.uniform(1.6, 2.5)), float(rng.uniform(45, 70)))
            for _ in range(n)]


#: A line 100 dB over the band at 1.7 cut-offs: 26 dB over it still through order 8's
#: skirt (74 dB down), so only order 16 (147 dB down) reads the band.
DEEP = (150.0, 0.03, 1.7, 100.0)


@pytest.mark.parametrize(("f0", "zeta", "offset", "db"), [*_cases(8), DEEP])
def test_a_line_outside_the_band_is_read_past_and_one_inside_is_not(f0, zeta, offset, db):
    rng = np.random.default_rng(int(f0 * 100))
    n = int(DURATION * FS)
    t = np.arange(n) / FS
    mode = _sdof(f0, zeta, n, rng)
    mode /= mode.std()
    w = max(RESOLUTION, 2 * zeta * f0)
    own = _band_power(mode, f0, w, FILTER_ORDER)
    # a sinusoid of amplitude a has band power a^2 / 4 where it passes
    amp = 2 * np.sqrt(own * 10 ** (db / 10))
    x = mode + amp * np.sin(2 * np.pi * (f0 + offset * w) * t + 0.3)
    # the leak is real: the order-4 skirt passes 1 / (1 + r^8)^2 of the line, and the
    # order-4 band signal holds it (closed forms of its power, and of the kurtosis of a
    # sinusoid of share p in Gaussian noise, 3 - 1.5 p^2)
    r = abs(offset)
    leak = amp ** 2 / 4 / (1 + r ** 8) ** 2
    z4, _ = band_envelope(x, FS, f0, w)
    assert np.mean(np.abs(z4) ** 2) == pytest.approx(own + leak, rel=0.2)
    p = leak / (own + leak)
    assert kurtosis_statistic(z4) == pytest.approx(3 - 1.5 * p ** 2, abs=0.2)
    # the check reads the band itself: the mode's power through the steeper filter
    # (Welch through its gain) and a Gaussian statistic above the limit
    rngs = np.random.default_rng(0), np.random.default_rng(1)
    read = band_statistic(x, FS, f0, zeta, w, ALPHA, *rngs, 1 / RESOLUTION)
    assert read.kurtosis > read.limit and abs(read.kurtosis - 3) < 0.35, read
    assert bool(read.note) == (read.order != FILTER_ORDER)
    if read.note:  # the order-4 reading was a sinusoid's: a steeper filter was read
        assert read.order in CHECK_ORDERS
        assert read.power == pytest.approx(_band_power(mode, f0, w, read.order), rel=0.2)
        # the check's draws come from its own stream: the main one has given exactly
        # the order-4 limit's draws, as without a check
        again = np.random.default_rng(0)
        z4, fs_z = band_envelope(x, FS, f0, w)
        kurtosis_limit(f0, zeta, w, fs_z, z4.size, ALPHA, again)
        assert rngs[0].random() == again.random()
    f = np.linspace(0, FS / 2, 1001)
    if (f0, zeta, offset, db) == DEEP:
        assert read.order == CHECK_ORDERS[-1]
    ev = cluster_evidence(f0, zeta, [x], ["y"], FS, f, np.ones_like(f), RESOLUTION, 0.6,
                          NO_LINES, np.random.default_rng(2))
    assert ev.kind == "mode", ev.text
    # a line inside the band (at the cluster, 10 dB over the band) keeps its power
    # through every filter: read as the sinusoid it is, by the order-4 filter alone
    line = 2 * np.sqrt(10 * own) * np.sin(2 * np.pi * f0 * t)
    read = band_statistic(mode + line, FS, f0, zeta, w, ALPHA, *rngs, 1 / RESOLUTION)
    assert read.kurtosis < read.limit and read.order == FILTER_ORDER and read.note == ""
    # and beside the leaking line, through whichever filter reads the band
    ev = cluster_evidence(f0, zeta, [x + line], ["y"], FS, f, np.ones_like(f), RESOLUTION,
                          0.6, NO_LINES, np.random.default_rng(2))
    assert ev.kind == "harmonic", ev.text


def test_a_steeper_filter_keeps_the_power_of_a_band_without_a_leak():
    # OWN_POWER against the closed form: a flat band keeps the ratio of the filters'
    # noise bandwidths, int 1 / (1 + r^(2n))^2 dr, order 8 over order 4 (1.05)
    nbw = {n: integrate.quad(lambda r, n=n: 1 / (1 + r ** (2 * n)) ** 2, 0, np.inf)[0]
           for n in (FILTER_ORDER, 8)}
    assert nbw[8] / nbw[FILTER_ORDER] == pytest.approx(1.05, abs=0.01)
    rng = np.random.default_rng(5)
    x = rng.standard_normal(int(DURATION * FS))
    z4, _ = band_envelope(x, FS, 100.0, 5.0)
    z8, _ = band_envelope(x, FS, 100.0, 5.0, 8, settled=True)
    ratio = np.mean(np.abs(z8) ** 2) / np.mean(np.abs(z4) ** 2)
    assert ratio == pytest.approx(nbw[8] / nbw[FILTER_ORDER], rel=0.05)
    assert ratio > 2 * OWN_POWER


def test_the_settled_start_up_of_a_steep_filter_drops_a_strong_lines_transient():
    # an order-8 low-pass started on a line 60 dB over the band: with the order-4
    # filter's fixed edge (2 / cut) its start-up burst is left in and the band reads
    # heavy-tailed; settled, the edge grows with the line's power and the band is
    # Gaussian again (the independent truth: the noise alone through the same filter)
    rng = np.random.default_rng(6)
    n = int(DURATION * FS)
    t = np.arange(n) / FS
    noise = rng.standard_normal(n)
    own = _band_power(noise, 120.0, 6.0, 8)
    x = noise + 2 * np.sqrt(own * 1e6) * np.sin(2 * np.pi * 108.0 * t)
    z_fixed, _ = band_envelope(x, FS, 120.0, 6.0, 8)
    z_settled, _ = band_envelope(x, FS, 120.0, 6.0, 8, settled=True)
    assert kurtosis_statistic(z_fixed) > 5
    assert kurtosis_statistic(z_settled) == pytest.approx(3.0, abs=0.3)
    assert np.mean(np.abs(z_settled) ** 2) == pytest.approx(own, rel=0.2)
