"""Motor torque -> torque meter pairings (N m per N m) through the identify stage.

The records are made by the true model of each pairing (:func:`gbpipe.model.truth_model`,
the bench with the motor's own loop opened), sampled with scipy; the identified FRF is
checked against that model's FRF by one linear solve per frequency, independently of the
truth dataset the stage reads.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy import signal

from gbpipe import model
from gbpipe.errors import DataError
from gbpipe.identify import frf_error_db, identify_record, match_bandwidth, model_matrices

FS = 5000.0
PAIRINGS = [{"name": "Tdrv_to_Mdrv", "inputs": ["motor_torque_driver"],
             "outputs": ["torque_meter_driving"]},
            {"name": "Tdrn_to_Mdrn", "inputs": ["motor_torque_driven"],
             "outputs": ["torque_meter_driven"]}]


def _direct(ss, f):
    eye = np.eye(ss.A.shape[0])
    return np.array([ss.C @ np.linalg.solve(2j * np.pi * fk * eye - ss.A, ss.B) + ss.D
                     for fk in f])


def _record(cfg, seed, n=int(8 * FS)):
    """White motor torques, each through its pairing's true model to its torque meter."""
    rng = np.random.default_rng(seed)
    ds = xr.Dataset(coords={"time": np.arange(n) / FS},
                    attrs={"sample_rate": FS, "test": "speed_up", "profile": "square"})
    for p in PAIRINGS:
        ss = model.truth_model(cfg, p["inputs"], p["outputs"])
        sysd = signal.cont2discrete((ss.A, ss.B, ss.C, ss.D), 1 / FS)
        u = 300.0 * rng.standard_normal(n)
        u[: int(FS)] = 0.0  # 1 s at the operating point
        _, y, _ = signal.dlsim(signal.dlti(*sysd[:4], dt=1 / FS), u[:, None])
        for name, x, offset in ((p["inputs"][0], u, 16250.0), (p["outputs"][0], y[:, 0],
                                                                  -16000.0)):
            ds[name] = ("time", x + offset, {"units": "N m"})
            ds[f"{name}_measured"] = ("time", x + offset + rng.standard_normal(n),
                                      {"units": "N m"})
    return ds


@pytest.fixture(scope="module")
def job(cfg):
    c = dict(cfg)
    c["campaign"] = {**cfg["campaign"], "settle": 1.0}
    c["identify"] = {**cfg["identify"], "versions": ["clean", "raw"], "past": 60,
                     "future": 30, "order": 24, "pairings": PAIRINGS,
                     "frf": {"f_min": 5.0, "f_max": 300.0, "points": 80}}
    f = np.geomspace(5.0, 300.0, 80)
    truth = model.truth_dataset(c, PAIRINGS, f, 300.0, c["identify"]["zeta_max"])
    rec, val = _record(cfg, 1), _record(cfg, 2)
    return c, truth, rec, val, identify_record(c, rec, val, truth, "pbsid")


def test_torque_meter_pairings_are_identified_in_n_m_per_n_m(job, cfg):
    c, truth, _, _, ds = job
    f = ds.frequency.values
    assert list(truth.output_units.values[:, 0]) == ["N m", "N m"]
    for p in PAIRINGS:
        key = f"{p['name']}/clean"
        assert str(ds.status.sel(model=key).values) == "ok"
        assert str(ds.frf_unit.sel(model=key).values) == "N·m/N·m"
        A, B, C, D = model_matrices(ds, key)
        dt = float(ds.sample_time)
        g_id = np.array([C @ np.linalg.solve(np.exp(2j * np.pi * fk * dt) * np.eye(len(A))
                                             - A, B) + D for fk in f])
        g_true = _direct(model.truth_model(cfg, p["inputs"], p["outputs"]), f)
        # noise-free data of the true model: within 1 dB from 5 Hz to >= 150 Hz, and the
        # stage's own bandwidth (against truth.nc) says the same within one grid step
        bw = match_bandwidth(f, frf_error_db(g_id, g_true), 1.0)
        assert bw >= 150.0, (p["name"], bw)
        assert abs(float(ds.match_bandwidth.sel(model=key)) - bw) <= 0.1 * bw
        assert np.all(ds.fit.sel(model=key).values[:1] > 90.0)


def test_a_record_in_other_units_than_the_truth_is_refused(job):
    c, truth, rec, val, _ = job
    rec = rec.copy()
    rec["torque_meter_driving"] = rec["torque_meter_driving"].assign_attrs(units="kN m")
    with pytest.raises(DataError, match="torque_meter_driving.*kN m.*truth.nc"):
        identify_record(c, rec, val, truth, "pbsid")
