"""Every kind of NetCDF output gbpipe writes passes the CF-1.11 compliance checker.

Each stage's dataset is built through the library at small size, written with
``gbpipe.io.write`` and checked with the IOOS compliance checker (all priorities, see
``tests/cf_check.py``). A negative control shows the check is not vacuous: the same kind
of data written by plain xarray has findings.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe import io, kinematics, model, simulate
from gbpipe.config import load
from gbpipe.model.dataset import frequency_grid, statespace_dataset
from tests.conftest import CONFIG
from tests.workflow.cf_check import cf_findings

# Short records: the CF structure of a file does not depend on its length.
_SHORT = {
    # no designed tests (their multisine period needs longer records): ramp tests only
    "campaign": {"settle": 0.5, "hold": 1.0, "designed": []},
    "identify": {"tests": ["speed_up", "speed_down", "torque_up", "torque_down"]},
    "sweep": {"duration": 33.0, "settle": 0.5, "sample_rate": 5000.0},
}


@pytest.fixture(scope="module")
def short_cfg():
    return load(CONFIG, _SHORT)


def _assert_compliant(path):
    findings = cf_findings(path)
    assert findings == [], f"{path.name}: {len(findings)} CF-1.11 findings:\n" + "\n".join(
        findings)


def test_kinematics_frequencies(tmp_path, short_cfg):
    ds = kinematics.frequencies(short_cfg["gearbox"]["stages"], 1120.0)
    ds.attrs["notes"] = "none"
    _assert_compliant(io.write(ds, tmp_path / "frequencies.nc", stage="kinematics",
                               config=short_cfg["gearbox"]))


def test_kinematics_frequencies_vs_rpm(tmp_path, short_cfg):
    ds = kinematics.frequencies(short_cfg["gearbox"]["stages"], [400.0, 800.0, 1120.0])
    ds = ds.assign_coords(rpm=("rpm", [400.0, 800.0, 1120.0],
                               {"units": "rev/min", "long_name": "HSS speed"}))
    _assert_compliant(io.write(ds, tmp_path / "frequencies_rpm.nc", stage="kinematics"))


def test_model_gearbox_and_bench(tmp_path, short_cfg):
    f = frequency_grid(1.0, 100.0, 12)
    mech, _ = model.gearbox_mechanism(short_cfg)
    gb = statespace_dataset(model.gearbox_ss(short_cfg), f, mech=mech)
    _assert_compliant(io.write(gb, tmp_path / "gearbox.nc", stage="model"))

    b_mech, _ = model.bench_mechanism(short_cfg)
    bench = statespace_dataset(model.bench_ss(short_cfg, closed=False), f, prefix="plant_",
                               mech=b_mech, frf_inputs=["motor_torque_driver"],
                               frf_outputs=["speed_gb1_hss", "torque_meter_driven"])
    bench = bench.merge(statespace_dataset(model.bench_ss(short_cfg), f, prefix="closed_",
                                           frf_inputs=["speed_ref", "torque_ref"],
                                           frf_outputs=["speed_lss"]))
    path = io.write(bench, tmp_path / "bench.nc", stage="model")
    _assert_compliant(path)
    # what the figures read back is what the model stage made
    back = io.read(path)
    xr.testing.assert_allclose(back.closed_A, bench.closed_A)
    assert back.closed_A.attrs == bench.closed_A.attrs


def test_simulated_test(tmp_path, short_cfg):
    ds = simulate.test(short_cfg, "speed_up", "square")
    # as rule campaign writes it: each series float32 where its spectrum leaves room
    path = io.write(ds, tmp_path / "speed_up_square.nc", stage="simulate",
                    wildcards={"test": "speed_up", "profile": "square"},
                    noisy=[v for v in ds.data_vars if ds[v].dims == ("time",)])
    _assert_compliant(path)
    with xr.open_dataset(path) as plain:
        assert {str(plain[v].dtype) for v in plain.data_vars} == {"float32", "float64"}


def test_sweep(tmp_path, short_cfg):
    ds = simulate.sweep(short_cfg)
    _assert_compliant(io.write(ds, tmp_path / "sweep.nc", stage="sweep", float32=True))


def test_generic_features(tmp_path):
    """Shapes of data a future stage may write: each must still come out compliant."""
    rng = np.random.default_rng(0)
    ds = xr.Dataset(
        {
            "psd": (("rpm", "frequency"), rng.random((3, 5)),
                    {"units": "(rad/s)^2/Hz", "long_name": "speed power spectral density"}),
            "level": (("rpm", "frequency"), rng.random((3, 5)),
                      {"units": "dB", "long_name": "level"}),
            "rate": ("case", [0.1, 0.2], {"units": "deg/s", "long_name": "rate"}),
            "flag": ("case", np.array([True, False]), {"units": "1", "long_name": "flag"}),
            "label": ("case", ["a", "bb"], {"units": "1", "long_name": "case description"}),
            "count": ("case", np.array([3, 4], dtype=np.int64),
                      {"units": "1", "long_name": "count"}),
            "gain": ((), 2.0, {"units": "mixed (see docs)", "long_name": "a gain"}),
        },
        coords={
            "rpm": ("rpm", [1120.0, 400.0, 800.0], {"units": "rev/min", "long_name": "speed"}),
            "frequency": ("frequency", np.linspace(0, 4, 5), {"units": "Hz",
                                                                "long_name": "frequency"}),
            "case": ("case", ["x", "y"], {"units": "1", "long_name": "case"}),
            "torque": ((), 16250.0, {"units": "N m", "long_name": "load torque"}),
        },
        attrs={"flag_list": [1, 2], "enabled": True},
    )
    _assert_compliant(io.write(ds, tmp_path / "generic.nc", stage="generic",
                               config={"x": 1}, wildcards={"case": "x"}))


def test_negative_control_plain_xarray_has_findings(tmp_path):
    """Without the writer's CF handling, the checker does flag our kind of data."""
    ds = xr.Dataset(
        {"rpm": ("state", [1.0, 2.0], {"units": "rev/min", "long_name": "speed"})},
        coords={"state": ("state", ["b", "a"], {"units": "1", "long_name": "state"})},
    )
    path = tmp_path / "plain.nc"
    ds.to_netcdf(path, engine="netcdf4")
    findings = cf_findings(path)
    assert any("rev/min" in f for f in findings), findings
    assert any("monotonic" in f for f in findings), findings
