"""Honest status: ok, poor or failed with a reason; unusable signals refused before any
fit; failed rows claim no band and no stability.

Expected verdicts follow from models built by hand (poles placed where the test wants
them) and from the definitions in docs/identify.md, not from the code's own output.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy import signal

from gbpipe.errors import DataError
from gbpipe.identify import identify_record, table_rows
from gbpipe.identify import stage as stage_module
from gbpipe.identify.status import assess, reference_growth_rate
from gbpipe.sysid import SubspaceModel

DT = 1e-3
S = {"fit_min": 50.0, "min_points": 10, "fit_segment": 2.0}


def _model(poles: np.ndarray) -> SubspaceModel:
    """A SISO model with the given discrete poles (complex ones with their conjugate)."""
    a = np.diag(np.asarray(poles, complex))
    n = a.shape[0]
    # a real realisation: any real matrix with these eigenvalues (similarity to companion)
    coeffs = np.real(np.poly(np.diag(a)))
    comp = np.zeros((n, n))
    comp[0] = -coeffs[1:]
    comp[1:, :-1] = np.eye(n - 1)
    return SubspaceModel(A=comp, B=np.eye(n, 1), C=np.ones((1, n)), D=np.zeros((1, 1)),
                         K=np.zeros((n, 1)), noise_cov=np.eye(1), singular_values=np.ones(n),
                         dt=DT, method="pbsid", order=n)


def _pair(f_hz: float, zeta: float) -> list[complex]:
    s = 2 * np.pi * f_hz * (-zeta + 1j * np.sqrt(1 - zeta**2))
    return [np.exp(s * DT), np.exp(np.conj(s) * DT)]


def test_stable_good_fit_on_enough_points_is_ok():
    v = assess(_model(_pair(60.0, 0.02)), np.array([80.0]), 40, 0.0, S)
    assert (v.status, v.stable) == ("ok", 1.0)


def test_a_model_built_unstable_is_poor_and_says_why():
    # a 60 Hz pair with zeta = -0.05: growth 2 pi 60 0.05 = 18.8 /s, x1.9e16 per 2 s segment
    v = assess(_model(_pair(60.0, -0.05)), np.array([80.0]), 40, 0.0, S)
    assert v.status == "poor" and v.stable == 0.0 and "unstable" in v.reason
    # the same growth against a reference whose own mode grows as fast is not a defect
    ref_rate = reference_growth_rate(np.array([60.0]), np.array([-0.05]))
    assert ref_rate == pytest.approx(2 * np.pi * 60 * 0.05)
    assert assess(_model(_pair(60.0, -0.05)), np.array([80.0]), 40, ref_rate, S).status == "ok"


def test_the_bench_unstable_mode_reproduced_is_stable_for_the_status():
    # the 1.3 Hz mode with one loop open (zeta = -0.023) against the truth that has it
    rate = reference_growth_rate(np.array([1.3, 62.0]), np.array([-0.023, 0.01]))
    v = assess(_model(_pair(1.3, -0.023) + _pair(62.0, 0.01)), np.array([90.0]), 200, rate, S)
    assert v.status == "ok"
    # against a nonparametric reference (no modes): it grows x1.46 per 2 s, under x2
    assert np.exp(2 * np.pi * 1.3 * 0.023 * 2.0) < 2.0
    assert assess(_model(_pair(1.3, -0.023)), np.array([90.0]), 200, 0.0, S).status == "ok"


@pytest.mark.parametrize("fit, points, why", [(49.9, 40, "fit_min"), (80.0, 9, "min_points"),
                                              (-5282.0, 3, "fit_min")])
def test_low_fit_or_thin_evidence_is_poor(fit, points, why):
    v = assess(_model(_pair(60.0, 0.02)), np.array([fit, 95.0]), points, 0.0, S)
    assert v.status == "poor" and why in v.reason
    if fit < 0 and points < 10:  # both unmet conditions are named
        assert "min_points" in v.reason


def test_no_model_or_non_finite_fit_is_failed_with_unknown_stability():
    v = assess(None, None, 0, 0.0, S, "ExcitationError: rank 11 < 74")
    assert v.status == "failed" and np.isnan(v.stable) and "rank 11" in v.reason
    v = assess(_model(_pair(60.0, 0.02)), np.array([np.nan]), 40, 0.0, S)
    assert v.status == "failed" and np.isnan(v.stable) and "not finite" in v.reason


FS = 1000.0


def _bench_record(seed: int, n: int = 20000, set_point: float | None = None) -> xr.Dataset:
    """A measured record: white torque through a lightly damped 40 Hz mode, 1 s at rest."""
    rng = np.random.default_rng(seed)
    u = 100.0 * rng.standard_normal(n)
    u[:int(FS)] = 0.0
    w = 2 * np.pi * 40.0
    a = np.array([[0.0, 1.0], [-w**2, -2 * 0.05 * w]])
    sysd = signal.cont2discrete((a, np.array([[0.0], [1e-3 * w**2]]), np.array([[1.0, 0.0]]),
                                 np.zeros((1, 1))), 1 / FS)
    y = signal.dlsim((*sysd[:4], 1 / FS), u)[1][:, 0]
    ds = xr.Dataset(coords={"time": np.arange(n) / FS},
                    attrs={"sample_rate": FS, "record": "bench7", "record_kind": "measured"})
    ds["torque"] = ("time", u + 500.0, {"units": "N m"})
    ds["speed"] = ("time", y + 0.01 * rng.standard_normal(n) + 100.0, {"units": "rad/s"})
    if set_point is not None:
        ds["set_point"] = ("time", np.full(n, set_point), {"units": "N m"})
    return ds


def _bench_cfg(cfg, **pairing):
    idc = {**cfg["identify"], "versions": ["raw"], "past": 40, "future": 20, "order": 4,
           "frf": {"f_min": 5.0, "f_max": 300.0, "points": 80}, "bounds": {
               **cfg["identify"]["bounds"], "groups": 0},
           "pairings": [{"name": "T_to_w", "inputs": ["torque"], "outputs": ["speed"],
                         **pairing}]}
    return {"campaign": {"settle": 0.5}, "identify": idc}


@pytest.fixture
def no_fit(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("a fit ran before the bad signal was refused")

    monkeypatch.setattr(stage_module, "fit_model", refuse)
    monkeypatch.setattr(stage_module, "fit_with_bounds", refuse)


def test_zero_variance_reference_is_refused_before_any_fit(cfg, no_fit):
    c = _bench_cfg(cfg, reference=["set_point"])
    with pytest.raises(DataError, match=r"record bench7, signal set_point.*no variance"):
        identify_record(c, _bench_record(1, set_point=0.0), None, None, "pbsid")


def test_input_without_band_excitation_is_refused_and_a_weak_one_is_not(cfg, no_fit):
    c = _bench_cfg(cfg)
    rec = _bench_record(2)
    t = rec.time.values
    slow = 200.0 * np.sin(2 * np.pi * 0.7 * t) + 80.0 * np.sin(2 * np.pi * 1.9 * t)
    rec["torque"] = ("time", slow + 500.0, {"units": "N m"})
    with pytest.raises(DataError, match=r"record bench7, signal torque.*no power in the "
                                        r"identified band 5-300 Hz"):
        identify_record(c, rec, None, None, "pbsid")
    # white noise 40 dB below the manoeuvre: in-band excitation, so it passes the check
    # and reaches the (here forbidden) fit
    noise = 0.01 * np.std(slow) * np.random.default_rng(3).standard_normal(t.size)
    rec["torque"] = ("time", slow + noise + 500.0, {"units": "N m"})
    with pytest.raises(AssertionError, match="a fit ran"):
        identify_record(c, rec, None, None, "pbsid")


def test_failed_row_has_no_bandwidth_and_unknown_stability(cfg):
    # the validation speed of the second half is NaN in the raw version only after 15 s:
    # one pairing's raw row fails (fit not finite), the other pairing's is unaffected
    c = _bench_cfg(cfg)
    c["identify"]["pairings"].append({"name": "T_to_w2", "inputs": ["torque"],
                                      "outputs": ["speed2"]})
    rec = _bench_record(4)
    spd = rec.speed.values.copy()
    spd[int(18 * FS):] = np.nan  # inside the held-out end
    rec["speed2"] = ("time", spd, {"units": "rad/s"})
    ds = identify_record(c, rec, None, None, "pbsid")
    bad, good = ds.sel(model="T_to_w2/raw"), ds.sel(model="T_to_w/raw")
    assert str(bad.status.values) == "failed" and "not finite" in str(bad.reason.values)
    assert np.isnan(float(bad.match_bandwidth)) and np.isnan(float(bad.stable))
    assert np.all(np.isnan(bad.element_match_bandwidth.values))
    assert str(good.status.values) in ("ok", "poor") and np.isfinite(float(good.match_bandwidth))
    rows = {r["pairing"]: r for r in table_rows([ds])}
    assert rows["T_to_w2"]["stable"] == "unknown" and np.isnan(rows["T_to_w2"]["achieved_hz"])
    assert rows["T_to_w2"]["status"] == "failed" and rows["T_to_w2"]["reason"]
    assert np.isnan(rows["T_to_w2"]["within_tol_pct"])
    # units: (rad/s)/(N·m) per model and for the file (all models share it)
    assert set(ds.frf_unit.values) == {"(rad/s)/(N·m)"}
    assert ds.frf_identified_real.attrs["units"] == "(rad/s)/(N·m)"
    assert ds.D.attrs["long_name"].endswith("(estimated)") == bool(c["identify"]["feedthrough"])


def _band_width(ds, key):
    # median log-width of the stored 95 % bounds of the reference where it is assessable
    sel = ds.sel(model=key)
    ok = sel.assessable.values > 0.5
    lo, hi = sel.frf_reference_lower.values[ok, 0, 0], sel.frf_reference_upper.values[ok, 0, 0]
    return float(np.median(np.log(hi / lo)))


def test_three_pooled_repeats_narrow_the_reference_bounds_by_sqrt3(cfg):
    # three repeats of one test (seeded noise): the pooled job's nonparametric estimate has
    # three times the averages, its bounds narrow as 1/sqrt(3); one multi-experiment model
    c = _bench_cfg(cfg)
    reps = [_bench_record(10 + k) for k in range(3)]
    for k, r in enumerate(reps):
        r.attrs.update(record=f"rep{k}", group="test7")
    one = identify_record(c, reps[0], None, None, "pbsid")
    pooled = identify_record(c, reps, None, None, "pbsid")
    ratio = _band_width(one, "T_to_w/raw") / _band_width(pooled, "T_to_w/raw")
    assert abs(ratio / np.sqrt(3) - 1) <= 0.2, ratio
    assert pooled.attrs["test"] == "test7" and pooled.attrs["records"] == "rep0,rep1,rep2"
    assert str(pooled.status.sel(model="T_to_w/raw").values) != "failed"


def test_bench_record_with_a_quiet_end_is_validated_on_its_excitation(cfg):
    # excitation only from 3 to 14 s of a 20 s record: the operating point is the mean
    # before 3 s (not campaign.settle = 5 s); the quiet end (-60 dB) is not held out: the
    # held-out 5 s reach 0.1 of the record's mean band power, so they hold >= 0.1 x 5/20
    # of the band energy: >= 0.025 x 11 s of the excitation (10 % slack: the floor, edges)
    c = _bench_cfg(cfg)
    c["campaign"] = {"settle": 5.0}
    rec = _bench_record(20)
    t = rec.time.values
    u = rec.torque.values - 500.0
    quiet = (t < 3.0) | (t >= 14.0)
    u[quiet] *= 1e-3
    rec["torque"] = ("time", u + 500.0, {"units": "N m"})
    ds = identify_record(c, rec, None, None, "pbsid")
    assert "before the inputs' first excitation" in ds.attrs["operating_point"]
    start, stop = (float(x) for x in ds.attrs["validation_test"].split()[2].split("-"))
    assert stop - start == pytest.approx(5.0, abs=0.01), ds.attrs["validation_test"]
    assert c["identify"]["holdout_power_min"] == 0.1
    assert start < 14.0 and min(stop, 14.0) - max(start, 3.0) >= 0.9 * 0.025 * 11.0, (
        ds.attrs["validation_test"])
