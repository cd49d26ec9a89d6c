"""Coverage of the jackknife FRF bounds (gbpipe.sysid.frf_bounds) over many seeds.

2-DOF torsional system (modes near 3.7 and 13 Hz, fs = 100 Hz) in open loop, white-noise
torque, white output noise at 20 dB SNR, N = 4000 samples. The whole grid 0.5-45 Hz is
identifiable at that SNR (every fit of the seeds below is within a few dB there), so the
coverage is counted over the whole grid: the fraction of (seed, frequency) pairs whose true
FRF lies inside the 95 % band must be 90-99 %, for magnitude and for phase.
"""

import numpy as np
import pytest
import scipy.signal as sig
from sysid_plants import torsional_plant

from gbpipe.errors import ConfigError
from gbpipe.sysid import frf_bounds

DT = 0.01
FREQ = np.linspace(0.5, 45.0, 120)
N = 4000
SNR_DB = 20.0


def record(seed: int, n: int = N):
    A, B, C, D = torsional_plant(DT)
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    y0 = sig.dlsim((A, B, C, D, DT), u)[1][:, 0]
    return u, y0 + 10 ** (-SNR_DB / 20) * y0.std() * rng.standard_normal(n)


def true_frf():
    A, B, C, D = torsional_plant(DT)
    z = np.exp(2j * np.pi * FREQ * DT)
    return np.array([C @ np.linalg.solve(zk * np.eye(4) - A, B) + D for zk in z])


@pytest.mark.parametrize(("method", "kw", "seeds"), [
    ("pbsid", {"past": 20, "future": 10}, 60),
    ("moesp", {"horizon": 10}, 50),
])
def test_truth_inside_the_95_percent_band_at_90_to_99_percent_of_frequencies(method, kw,
                                                                               seeds):
    g = true_frf()
    in_mag, in_phase = [], []
    for seed in range(seeds):
        u, y = record(seed)
        b = frf_bounds(method, u, y, FREQ, n_groups=10, order=4, dt=DT, **kw)
        assert b.frf.shape == g.shape and b.n_groups == 10
        assert np.all(b.mag_db_lower <= b.mag_db) and np.all(b.mag_db <= b.mag_db_upper)
        m, p = b.contains(g)
        in_mag.append(m)
        in_phase.append(p)
    cov_mag, cov_phase = np.mean(in_mag), np.mean(in_phase)
    assert 0.90 <= cov_mag <= 0.99, f"magnitude coverage {cov_mag:.3f}"
    assert 0.90 <= cov_phase <= 0.99, f"phase coverage {cov_phase:.3f}"


def test_bounds_narrow_with_more_data():
    # Four times the data: the band should shrink by about 2 (1/sqrt(N)); the median width
    # over three seeds varies, so accept 1.3..3.
    width = {
        n: np.mean([np.median(b.mag_db_upper - b.mag_db_lower) for b in (
            frf_bounds("pbsid", *record(seed, n), FREQ, order=4, past=20, future=10, dt=DT)
            for seed in (200, 201, 202))])
        for n in (N, 4 * N)
    }
    assert 1.3 <= width[N] / width[4 * N] <= 3.0


def test_bad_arguments_name_the_field():
    u, y = record(0)
    with pytest.raises(ConfigError, match="n_groups"):
        frf_bounds("pbsid", u, y, FREQ, n_groups=2, order=4, past=20)
    with pytest.raises(ConfigError, match="method"):
        frf_bounds("arx", u, y, FREQ, order=4)
    with pytest.raises(ConfigError, match="confidence"):
        frf_bounds("pbsid", u, y, FREQ, confidence=95, order=4, past=20)
