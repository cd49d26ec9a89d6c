"""Identify-layer numerics: channel scaling of a MIMO fit, the segment validation fit, and
conditioning each signal once.

Expected values are independent of the code under test: the true FRF of a known system
built with python-control (its own frequency response), the per-segment least-squares
initial state of :meth:`gbpipe.sysid.SubspaceModel.estimate_x0`, and :func:`condition` of
the stacked signals.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
import xarray as xr

from gbpipe.identify import ConditionedRecord, condition, fit_model, frf_error_db
from gbpipe.lti import dlsim
from gbpipe.sysid import SubspaceModel

DT = 1e-3
F = np.geomspace(5.0, 300.0, 60)
SETTINGS = {"order": 4, "max_order": 4, "past": 20, "future": 10, "lowpass": 0.8,
            "reflect_out_of_band": False, "factor": "auto",
            "feedthrough": False}


def _plant() -> control.StateSpace:
    """2 x 2 plant: modes at 40 Hz (zeta 0.03) and 150 Hz (zeta 0.05), sampled at 1 kHz."""
    w1, w2 = 2 * np.pi * 40.0, 2 * np.pi * 150.0
    a = np.array([[0, 1, 0, 0], [-w1**2, -2 * 0.03 * w1, 0, 0],
                  [0, 0, 0, 1], [0, 0, -w2**2, -2 * 0.05 * w2]])
    b = np.array([[0, 0], [1.0, 0.4], [0, 0], [0.5, 1.0]])
    c = np.array([[w1**2, 0, 0.3 * w2**2, 0], [0.2 * w1**2, 0, w2**2, 0]])
    return control.sample_system(control.ss(a, b, c, np.zeros((2, 2))), DT, method="zoh")


def _data(plant, u_scale, y_scale, seed=3, n=20_000, noise=1e-3):
    """White inputs through the plant, output noise; channel k of u is in units
    ``u_scale[k]`` times smaller (the plant's B column k times larger), the same for y."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 2))
    y = dlsim(plant.A, plant.B, plant.C, plant.D, u) + noise * rng.standard_normal((n, 2))
    return u * u_scale, y * y_scale


def _true_frf(plant, u_scale, y_scale):
    # python-control's own frequency response, in the scaled units
    g = np.moveaxis(plant.frequency_response(2 * np.pi * F).complex, -1, 0)
    return g * np.asarray(y_scale)[None, :, None] / np.asarray(u_scale)[None, None, :]


@pytest.mark.parametrize("method", ["pbsid", "moesp"])
def test_mimo_fit_is_in_physical_units_whatever_the_channel_scales(method):
    # Inputs 1e4 apart (N m against a tiny input) and outputs 1e4 apart: the identified
    # FRF in physical units is as accurate as with equal scales, and it is the same model.
    plant = _plant()
    errs, models = [], []
    for us, ys in (([1.0, 1.0], [1.0, 1.0]), ([1.0, 1e-4], [1.0, 1.0]),
                   ([1e4, 1.0], [1.0, 1e-4])):
        u, y = _data(plant, us, ys)
        m = fit_model(method, u, y, DT, SETTINGS)
        errs.append(np.abs(frf_error_db(m.frf(F), _true_frf(plant, us, ys))).max())
        models.append((m, np.asarray(us), np.asarray(ys)))
    assert errs[0] < 0.5, errs
    np.testing.assert_allclose(errs[1:], errs[0], atol=0.05)
    # every matrix in physical units: the FRF and the innovation covariance scale as the
    # channels do (noise 1e-3 rms on each output before scaling)
    m0 = models[0][0]
    for m, us, ys in models[1:]:
        np.testing.assert_allclose(m.frf(F) * us[None, None, :] / ys[None, :, None],
                                   m0.frf(F), rtol=1e-3)
        np.testing.assert_allclose(np.diag(m.noise_cov) / ys**2, np.diag(m0.noise_cov),
                                   rtol=1e-3)
    np.testing.assert_allclose(np.sqrt(np.diag(m0.noise_cov)), 1e-3, rtol=0.2)


def _model(rho: float, seed: int = 0) -> SubspaceModel:
    rng = np.random.default_rng(seed)
    n = 6
    a = np.diag(rng.uniform(-0.9, 0.9, n))
    a[:2, :2] = rho * np.array([[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]])
    return SubspaceModel(a, rng.standard_normal((n, 2)), rng.standard_normal((2, n)),
                         np.zeros((2, 2)), np.zeros((n, 2)), np.eye(2), np.ones(n), DT,
                         "pbsid", n)


@pytest.mark.parametrize("rho", [0.98, 1.0, 1.0005, 1.01])
def test_segment_simulation_is_the_per_segment_least_squares_fit(rho):
    # the validation fit's one-pass simulation (SubspaceModel.simulate_segments)
    # reference: each segment simulated from its own estimate_x0 (lstsq on the free
    # responses), a last segment shorter than the order copied from y
    m = _model(rho)
    rng = np.random.default_rng(1)
    n, seg = 7003, 1000
    u = rng.standard_normal((n, 2))
    y = m.simulate(u) + 0.05 * rng.standard_normal((n, 2))
    y[:, 1] += np.linspace(0, 3, n)  # a drift only the restarts absorb
    ref = np.empty_like(y)
    for a in range(0, n, seg):
        b = min(n, a + seg)
        if b - a < m.order:
            ref[a:b] = y[a:b]
        else:
            ref[a:b] = m.simulate(u[a:b], m.estimate_x0(u[a:b], y[a:b]))
    got = m.simulate_segments(u, y, seg)[0]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * np.abs(y).max())
    got = m.simulate_segments(u[:-1], y[:-1], seg)[0]  # last segment 2 samples < order
    np.testing.assert_allclose(got[-2:], y[-3:-1], rtol=0, atol=1e-12 * np.abs(y).max())


def test_conditioned_record_is_condition_of_the_stacked_signals():
    fs = 5000.0
    rng = np.random.default_rng(4)
    n = 20_000
    ds = xr.Dataset({k: ("time", 10.0 + rng.standard_normal(n)) for k in ("a", "b", "c")},
                    attrs={"sample_rate": fs})
    removed = xr.Dataset({k: ("time", rng.standard_normal(n)) for k in ("a", "b")})
    rec = ConditionedRecord(ds, {"tsa": removed}, fs, 0.5, 1000.0)
    want = condition([ds["b"].values, ds["a"].values], fs, 0.5, 1000.0)
    np.testing.assert_array_equal(rec(["b", "a"], "clean"), want)
    np.testing.assert_array_equal(rec(["a", "c", "b"], "clean")[:, [2, 0]], want)
    np.testing.assert_array_equal(rec(["a"], "tsa")[:, 0],
                                  condition([removed["a"].values], fs, 0.5, 1000.0)[:, 0])
    with pytest.raises(ValueError, match="not in the record"):
        rec(["c"], "tsa")


@pytest.mark.parametrize("fs_out", [1000.0, 5000.0])
def test_conditioned_samples_times_are_where_a_ramp_says(fs_out):
    # a linear-phase FIR of unit DC gain passes a ramp delayed by its group delay, exactly:
    # the conditioned ramp of the time axis is the time each sample was taken
    fs, n, t0 = 5000.0, 20_000, 3.25
    t = t0 + np.arange(n) / fs
    ds = xr.Dataset({"ramp": ("time", t)}, coords={"time": t},
                    attrs={"sample_rate": fs, "record_kind": "measured"})
    rec = ConditionedRecord(ds, {}, fs, 0.5, fs_out)
    got = rec(["ramp"], "raw")[:, 0] + np.mean(t[:int(0.5 * fs)])  # operating point back
    assert rec.times().shape == got.shape
    np.testing.assert_allclose(rec.times(), got, rtol=0, atol=1e-9)
