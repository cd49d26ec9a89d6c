"""The virtual stage on the shaft-line example's chain (tests/measured/shaftline_bench.py:
the project's closed loop, exact ZOH, 2 % sensor noise): the held-out torque meter before
the gearbox estimated from the other signals; the load spectra against an independent
count; refusals.

The stage runs in blocks of 1009 samples here (issue 47: the output written, the held-out
comparison and the load spectra accumulated block by block; 12 blocks): the held-out
comparison must equal lti.fit_percent and plain numpy on the whole steady part, the load
spectra the rainflow library's count, numpy's histogram and the DEL formula on the whole
series."""

from __future__ import annotations

import numpy as np
import pytest
import rainflow
import xarray as xr

from gbpipe import io
from gbpipe.config import load
from gbpipe.errors import ConfigError
from gbpipe.lti import fit_percent
from gbpipe.measured import read
from gbpipe.virtual import Z95, stage, table_rows, virtual_record
from tests.conftest import CONFIG, ROOT
from tests.loads.test_spectra import four_point
from tests.measured.shaftline_bench import write_bench
from tests.virtual.chains import simulate_chain
from tests.workflow.cf_check import cf_findings

EXAMPLE = ROOT / "config" / "examples" / "shaftline.yaml"
#: Samples per block of the stage's passes in these tests.
SMALL = 1009


@pytest.fixture(scope="module")
def shaftline(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shaftline")
    truth = write_bench(folder / "shaftline", duration=6.0, seed=7)
    cfg = load(CONFIG, EXAMPLE, {"virtual": {"noise": {"window": [0.0, 3.0]}}})
    spec = cfg["measured"]["run1"]
    record = read(spec, folder, name="run1")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(stage, "BLOCK", SMALL)
        out = virtual_record(cfg["virtual"], {"drivetrain": cfg["drivetrain"]}, record,
                             "run1", folder / "virtual.nc")
    assert record.sizes["time"] > 10 * SMALL
    return cfg, truth, io.read(out), record


def test_held_out_torque_meter(shaftline):
    cfg, truth, ds, _ = shaftline
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
    cfg, truth, ds, _ = shaftline
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


def test_holdout_comparison_equals_the_whole_steady_part(shaftline):
    _, _, ds, _ = shaftline
    k = ds.steady.values.astype(bool)
    for i, h in enumerate(ds.holdout.values):
        j = list(ds.target.values).index(h)
        m, z = ds.holdout_measured.values[k, i], ds.estimate.values[k, j]
        assert float(ds.holdout_fit_percent[i]) == pytest.approx(
            fit_percent(m - m.mean(), z - z.mean())[0], rel=1e-10)
        assert float(ds.holdout_fit_percent_with_mean[i]) == pytest.approx(
            fit_percent(m, z)[0], rel=1e-10)
        assert float(ds.holdout_rms_error[i]) == pytest.approx(
            np.sqrt(np.mean((m - z) ** 2)), rel=1e-10)
        half = Z95 * np.hypot(float(ds.estimate_sd[j]), float(ds.holdout_noise_sd[i]))
        assert float(ds.holdout_coverage_95[i]) == np.mean(np.abs(m - z) <= half)


def test_spectra_equal_the_library_on_the_whole_series(shaftline):
    cfg, _, ds, record = shaftline
    k = ds.steady.values.astype(bool)
    dt = float(np.median(np.diff(ds.time.values)))
    slopes = ds.sn_slope.values
    bins = cfg["virtual"]["spectra"]["bins"]
    sources = set()
    for i, name in enumerate(ds.signal.values):
        name = str(name)
        sources.add(str(ds.signal_source.values[i]))
        if ds.signal_source.values[i] == "measured":
            x = record[name].values[k]
        else:
            x = ds.estimate.values[k, list(ds.target.values).index(name)]
        pairs = rainflow.count_cycles(x)
        ranges, counts = np.array(pairs).T
        edges = np.linspace(0.0, ranges.max(), bins + 1)
        assert np.allclose(ds.cycle_count.values[i],
                           np.histogram(ranges, edges, weights=counts)[0], atol=1e-9), name
        assert np.allclose(ds.cycle_range.values[i], 0.5 * (edges[1:] + edges[:-1]))
        levels = np.linspace(x.min(), x.max(), bins + 1)
        assert np.array_equal(ds.time_at_level.values[i], np.histogram(x, levels)[0] * dt)
        n_eq = cfg["virtual"]["spectra"]["equivalent_frequency"] * len(x) * dt
        want = [(np.sum(counts * ranges ** m) / n_eq) ** (1 / m) for m in slopes]
        assert np.allclose(ds["del"].values[i], want, rtol=1e-12), name
    assert sources == {"measured", "estimated"}


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
