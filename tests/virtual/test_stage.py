"""The virtual stage on the shaft-line example's chain (tests/measured/shaftline_bench.py:
the project's closed loop, exact ZOH, 2 % sensor noise): the held-out torque meter before
the gearbox estimated from the other signals; the load spectra against an independent
count; refusals."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe import io
from gbpipe.config import load
from gbpipe.errors import ConfigError
from gbpipe.measured import read
from gbpipe.virtual import table_rows, virtual_record
from tests.conftest import CONFIG, ROOT
from tests.loads.test_spectra import four_point
from tests.measured.shaftline_bench import write_bench
from tests.virtual.chains import simulate_chain
from tests.workflow.cf_check import cf_findings

EXAMPLE = ROOT / "config" / "examples" / "shaftline.yaml"


@pytest.fixture(scope="module")
def shaftline(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shaftline")
    truth = write_bench(folder / "shaftline", duration=6.0, seed=7)
    cfg = load(CONFIG, EXAMPLE, {"virtual": {"noise": {"window": [0.0, 3.0]}}})
    spec = cfg["measured"]["run1"]
    record = read(spec, folder, name="run1")
    out = virtual_record(cfg["virtual"], {"drivetrain": cfg["drivetrain"]}, record, "run1",
                         folder / "virtual.nc")
    return cfg, truth, io.read(out)


def test_held_out_torque_meter(shaftline):
    cfg, truth, ds = shaftline
    (row,) = table_rows(ds, "run1")
    assert row["signal"] == "torque_input"
    assert row["fit_percent"] >= 95.0
    assert 0.90 <= row["coverage_95"] <= 0.99
    # the estimate of the held-out sensor's spring and of the sensor are one signal
    t = list(ds.target.values)
    assert np.allclose(ds.estimate.values[:, t.index("torque_input")],
                       ds.estimate.values[:, t.index("torque_coupling_gear")])
    # the record has no offsets: every estimated offset within its 95 % interval of 0
    assert np.all(np.abs(ds.offset_value.values) <= 1.96 * ds.offset_sd.values)


def test_spectra_of_a_measured_torque_equal_an_independent_count(shaftline):
    cfg, truth, ds = shaftline
    k = list(ds.signal.values).index("torque_output")
    steady = ds.steady.values.astype(bool)
    # the spectra count the steady part (the estimates' transients left out)
    x = truth.signals["torque_output"][steady]
    ref = four_point(x.astype(np.float32).astype(float))
    m = 4.0
    s = list(ds.sn_slope.values).index(m)
    n_eq = cfg["virtual"]["spectra"]["equivalent_frequency"] * len(x) / 2000.0
    want = (sum(n * r ** m for r, n in ref.items()) / n_eq) ** (1 / m)
    assert float(ds["del"].values[k, s]) == pytest.approx(want, rel=1e-3)
    assert float(ds.time_at_level.values[k].sum()) == pytest.approx(len(x) / 2000.0,
                                                                    rel=1e-9)


def test_unknown_names_refused_by_key():
    files = (CONFIG, EXAMPLE)
    for overlay, field in (({"virtual": {"holdout": ["torque_inpt"]}}, "virtual.holdout[0]"),
                           ({"virtual": {"records": ["run2"]}}, "virtual.records[0]"),
                           ({"virtual": {"model": "fitted", "records": ["run1"]},
                             "fit": {"records": []}}, "virtual.model"),
                           ({"virtual": {"sensors": ["torque_input"]}}, "virtual.holdout"),
                           ({"virtual": {"noise": {"window": [5.0, 1.0]}}},
                            "virtual.noise.window")):
        with pytest.raises(ConfigError) as exc:
            load(*files, overlay)
        assert exc.value.field == field


def test_output_is_cf_compliant_and_reads_back(tmp_path):
    """A short record of a random openTorsion chain through the stage, written with
    gbpipe.io: no CF-1.11 finding (a zero-length load dimension included), and the
    variables the data contract lists read back."""
    rec = simulate_chain(11, n_disks=4, duration=1.5)
    t = np.arange(len(rec.u_measured)) * rec.dt
    record = xr.Dataset(
        {"motor_torque_drive": ("time", rec.u_measured[:, 0]),
         **{k: ("time", v) for k, v in rec.y.items()},
         "torque_first": ("time", rec.torque[:, 0] + 0.5 * np.random.default_rng(1)
                          .standard_normal(len(t)))},
        coords={"time": t})
    cfg = load(CONFIG, {"virtual": {"holdout": ["torque_first"], "speeds": ["n2"],
                                    "noise": {"window": [0.0, 1.0]}}})
    path = virtual_record(cfg["virtual"], {"drivetrain": rec.description}, record, "chain",
                          tmp_path / "chain.nc",
                          provenance={"config": cfg["virtual"], "wildcards": {"record": "chain"}})
    assert cf_findings(path) == []
    back = io.read(path)
    assert back.sizes["load"] == 0
    assert back.attrs["stage"] == "virtual" and back.attrs["wildcard_record"] == "chain"
    assert set(back.data_vars) == {
        "estimate", "lower", "upper", "estimate_sd", "steady", "offset_value", "offset_sd",
        "sensor_noise_sd", "input_noise_sd", "load_step_sd", "model_noise_sd",
        "holdout_measured", "holdout_fit_percent", "holdout_fit_percent_with_mean",
        "holdout_rms_error", "holdout_coverage_95", "holdout_noise_sd", "cycle_range",
        "cycle_count", "load_level", "time_at_level", "del", "signal_source"}
    assert list(back.target.values) == ["torque_shaft0", "torque_shaft1", "torque_shaft2",
                                        "speed_n2", "torque_first"]
