"""The identify stage's FRF bounds (gbpipe.identify.fit_with_bounds): the jackknife of
gbpipe.sysid.frf_bounds around the stage's own model, scaling with the noise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from gbpipe.identify import fit_model
from gbpipe.identify.fitting import fit_with_bounds

DT = 1e-3


def _plant():
    # two lightly damped modes (40 Hz, 120 Hz), discretised exactly (ZOH)
    num, den = [1.0], [1.0]
    for f, z in ((40.0, 0.03), (120.0, 0.02)):
        w = 2 * np.pi * f
        num, den = np.polymul(num, [w**2]), np.polymul(den, [1.0, 2 * z * w, w**2])
    return signal.cont2discrete(signal.tf2ss(num, den), DT, method="zoh")


def _data(noise: float, seed: int = 0, n: int = 12000):
    a, b, c, d, _ = _plant()
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    _, y, _ = signal.dlsim((a, b, c, d, DT), u)
    return u[:, None], (y[:, 0] + noise * np.std(y) * rng.standard_normal(n))[:, None]


S = {"order": 4, "max_order": 10, "past": 20, "future": 10, "lowpass": 0.8,
     "reflect_out_of_band": False, "factor": "auto", "feedthrough": False,
     "bounds": {"groups": 5, "confidence": 0.95}}


@pytest.mark.parametrize("method", ["pbsid", "moesp"])
def test_bounds_bracket_the_stage_model_and_shrink_with_the_noise(method):
    f = np.geomspace(5.0, 300.0, 40)
    width = {}
    for noise in (0.3, 0.03):
        u, y = _data(noise)
        m, lo, hi = fit_with_bounds(method, u, y, DT, S, f)
        # the returned model is the stage's own fit of all the data
        g = m.frf(f)
        np.testing.assert_allclose(g, fit_model(method, u, y, DT, S).frf(f), rtol=1e-8)
        mag = 20 * np.log10(np.abs(g))
        assert np.all(lo <= mag + 1e-9) and np.all(mag <= hi + 1e-9)
        width[noise] = float(np.median(hi - lo))
    # the jackknife measures scatter: ten times less noise, a band several times narrower
    assert width[0.03] < width[0.3] / 4, width
