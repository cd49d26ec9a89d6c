"""The DaISy protocol on measured records, checked against an independent computation.

The records are vendored in ``tests/data/daisy`` (``SOURCE.md`` there). The reference is
:mod:`arx_reference`: least-squares ARX models (numpy only, no code shared with gbpipe),
run through the same protocol. Two claims are tested on data the models never saw:

* each subspace model predicts the test segment at least as well as the ARX model the
  same protocol selects (fewer parameters, at least as good: the claim of subspace
  identification on these records);
* on ``robot_arm`` (one input, a swept sine that excites its resonances) the model's
  frequency response agrees with that of a high-order ARX model, a consistent estimate
  of the true one, where the input carries power.
"""

import numpy as np
import pytest
import scipy.signal as sig
from arx_reference import arx_protocol, fit_arx
from daisy_protocol import DATA, load_daisy, run_protocol

CASES = [(name, method) for name in ("robot_arm", "CD_player_arm")
         for method in ("pbsid", "moesp", "n4sid")]


@pytest.fixture(scope="module")
def arx_reference():
    return {name: arx_protocol(*load_daisy(name)[:2]) for name in ("robot_arm", "CD_player_arm")}


@pytest.mark.parametrize(("name", "method"), CASES)
def test_daisy_protocol_against_arx_reference(name, method, arx_reference):
    u, y, dt = load_daisy(name)
    u0, y0 = u.copy(), y.copy()
    res = run_protocol(u, y, method, dt)
    assert res.model.is_stable()
    assert np.max(np.abs(np.linalg.eigvals(res.model.A - res.model.K @ res.model.C))) < 1
    _, arx_fit = arx_reference[name]
    # At least as good on the unseen test segment as the independent ARX reference (mean
    # over outputs). Measured: ARX reference 94.3 % (robot_arm, order 9) and 76.5 %
    # (CD_player_arm, order 2); subspace models 95.6-96.6 % and 77.4-79.5 %.
    assert res.test_fit.mean() >= arx_fit.mean(), (res.order, res.test_fit, arx_fit)
    # And far better than a static gain u -> y fitted on the same estimation segment.
    n = len(u)
    a, b = int(0.6 * n), int(0.8 * n)
    uc, yc = u - u[:a].mean(0), y - y[:a].mean(0)
    g, *_ = np.linalg.lstsq(uc[:a], yc[:a], rcond=None)
    static = 100 * (1 - np.linalg.norm(yc[b:] - uc[b:] @ g, axis=0)
                    / np.linalg.norm(yc[b:] - yc[b:].mean(0), axis=0))
    assert res.test_fit.mean() > static.mean() + 2, (res.test_fit, static)
    np.testing.assert_array_equal(u, u0)
    np.testing.assert_array_equal(y, y0)


@pytest.mark.parametrize("method", ["pbsid", "moesp", "n4sid"])
def test_robot_arm_frf_matches_high_order_arx(method):
    u, y, dt = load_daisy("robot_arm")
    res = run_protocol(u, y, method, dt)
    a = int(0.6 * len(u))
    uc, yc = u - u[:a].mean(0), y - y[:a].mean(0)
    reference = fit_arx(uc[:a], yc[:a], 20, 21)
    f = np.linspace(0.0, 0.5, 65)[1:-1]  # cycles per sample
    # The band where the input carries power: Welch PSD within 20 dB of its peak.
    f_psd, p_u = sig.welch(uc[:a, 0], nperseg=128)
    band = np.interp(f, f_psd, p_u) > 0.01 * p_u.max()
    assert band.sum() >= 10
    g_ref = reference.frf(f)[band, 0, 0]
    g = res.model.frf(f[band] / dt)[:, 0, 0]
    err = np.abs(g - g_ref) / np.abs(g_ref)
    # Measured: median 1.3 % (PBSID, order 7), 2.7 % (N4SID, 8), 5.6 % (MOESP, 4: its lower
    # order misses a little of the response). A gain off by 20 % already gives 20 %.
    assert np.median(err) < 0.12, np.round(err, 3)


def test_load_daisy_errors(tmp_path):
    assert (DATA / "robot_arm.dat").is_file()
    with pytest.raises(ValueError, match="unknown DaISy record 'nope'"):
        load_daisy("nope")
    with pytest.raises(FileNotFoundError, match="robot_arm.dat not found"):
        load_daisy("robot_arm", tmp_path)
