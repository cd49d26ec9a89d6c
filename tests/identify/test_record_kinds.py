"""The clusters of a record judged together: a band that holds a lighter mode, against an
independent simulation of two modes (scipy) and the statistic's own scatter."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from gbpipe.identify.band_kurtosis import kurtosis_limit, kurtosis_statistic
from gbpipe.identify.band_signal import band_envelope
from gbpipe.identify.harmonic_lines import HarmonicBands
from gbpipe.identify.mode_kinds import ALPHA, Evidence, cluster_evidence
from gbpipe.identify.record_kinds import Cluster, PairingData, _lighter_mode, record_evidence
from tests.identify.sdof import sdof_response

FS = 1000.0
NO_LINES = HarmonicBands(np.array([]), np.array([]), np.array([]), (np.nan, np.nan))
#: A heavy mode with a light one within a frequency line (0.5 Hz) of it, whose peak is
#: then the band's sinusoid at the pole (the damping of case 22 of the modal benchmark's
#: seed 3, benchmarks/modal_selection.py, whose light mode lies further off).
HEAVY, LIGHT = (106.4, 0.093), (106.8, 0.006)


def _two_modes(seed: int, n: int) -> np.ndarray:
    # both modes driven by unit white noise, simulated by scipy (tests/identify/sdof.py)
    rng = np.random.default_rng(seed)
    return (sdof_response(*HEAVY, n, rng, FS) + sdof_response(*LIGHT, n, rng, FS))


def test_a_band_holding_a_lighter_mode_scatters_as_the_lighter_modes():
    """100 records of 40 s of the two modes: the heavy mode's band statistic falls under
    the limit drawn for the heavy mode alone far more often than ALPHA (the light mode's
    longer correlation widens its scatter), and never under the limit drawn for the
    lighter mode, which lies at or below the statistic's own ALPHA quantile (log-normal,
    as the limit is drawn)."""
    n = int(40 * FS)
    w = 2 * HEAVY[1] * HEAVY[0]
    ks = []
    for seed in range(100):
        z, fs_z = band_envelope(_two_modes(seed, n), FS, HEAVY[0], w)
        ks.append(float(kurtosis_statistic(z)))
    ks = np.array(ks)
    own = kurtosis_limit(*HEAVY, w, fs_z, z.size, ALPHA, np.random.default_rng(0))
    lighter = kurtosis_limit(HEAVY[0], LIGHT[1] * LIGHT[0] / HEAVY[0], w, fs_z, z.size,
                             ALPHA, np.random.default_rng(0))
    assert np.mean(ks < own) >= 0.03, (own, np.sort(ks)[:5])  # 30 ALPHA and more
    assert not np.any(ks < lighter), (lighter, ks.min())
    lg = np.log(ks)
    quantile = np.exp(lg.mean() - stats.norm.isf(ALPHA) * lg.std(ddof=1))
    assert lighter <= quantile + 0.05 and own > quantile + 0.1, (lighter, own, quantile)


def test_a_record_judges_a_band_that_holds_a_lighter_mode_against_its_limit():
    """A draw of the two modes (seed 10 of the test above) whose heavy band reads 2.64:
    under the heavy mode's limit (2.78), over the lighter mode's (2.51). Judged alone the
    heavy cluster is a sinusoid; judged in its record, beside the light mode's cluster,
    it is the mode it is, and the evidence names the lighter mode. The light cluster is
    a mode either way, and no line is placed (no sinusoid is left)."""
    y = _two_modes(10, int(40 * FS))
    f = np.linspace(0, FS / 2, 1001)
    alone = cluster_evidence(*HEAVY, [y], ["y"], FS, f, np.ones_like(f), 0.5, 0.6, NO_LINES,
                             np.random.default_rng(0))
    assert alone.kind == "harmonic" and alone.sinusoid, alone.text
    data = [PairingData(y[:, None], ["y"], FS, f, np.ones_like(f))]
    ev, own = record_evidence([Cluster(0, *HEAVY), Cluster(0, *LIGHT)], data, NO_LINES, [],
                              0.5, 0.6, 2, 400.0, 0)
    assert [e.kind for e in ev] == ["mode", "mode"], [e.text for e in ev]
    assert ev[0].kurtosis == pytest.approx(alone.kurtosis)
    assert ev[0].kurtosis_limit < ev[0].kurtosis < alone.kurtosis_limit, ev[0].text
    assert "the lighter mode at 106.8 Hz" in ev[0].text
    assert own.order.size == 0


def test_the_lighter_mode_is_the_narrowest_mode_of_the_pairing_in_the_band():
    """Which cluster's limit a band takes (`_lighter_mode`), on hand-made clusters about a
    5 % cluster at 100 Hz (its band 90-110 Hz): the narrowest `mode` of the same pairing
    in the band, narrower than the cluster; never a line, another pairing's mode, a
    wider mode or one outside the band."""
    ev = {"mode": Evidence("mode", "", 3.0, 2.5, 1.0, np.nan, False, False),
          "harmonic": Evidence("harmonic", "", 1.5, 2.5, 1.0, np.nan, False, True)}
    others = [(Cluster(0, 104.0, 0.02), "mode"),  # 2.1 Hz half-power half-width
              (Cluster(0, 97.0, 0.01), "mode"),  # 0.97 Hz: the narrowest
              (Cluster(1, 101.0, 0.001), "mode"),  # another pairing
              (Cluster(0, 102.0, 0.0005), "harmonic"),  # a line
              (Cluster(0, 99.0, 0.08), "mode"),  # wider than the cluster
              (Cluster(0, 115.0, 0.001), "mode")]  # outside the band
    c = Cluster(0, 100.0, 0.05)

    def lighter(kept: list) -> tuple[float, float] | None:
        clusters = [c] + [o for o, _ in kept]
        return _lighter_mode(c, clusters, [ev["harmonic"]] + [ev[k] for _, k in kept], 0.5)

    assert lighter(others) == (97.0, 0.01)
    assert lighter([o for o in others if o[0].frequency_hz != 97.0]) == (104.0, 0.02)
    assert lighter(others[2:]) is None  # no narrower mode of its pairing in its band
