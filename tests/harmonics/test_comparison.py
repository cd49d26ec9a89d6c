"""Tests of gbpipe.harmonics.comparison (the removal-comparison stage) on the synthetic
sweep of :mod:`harmonic_sweeps`, whose harmonic and broadband parts are known exactly:
the broadband part is the 62 Hz resonance response to white noise, the harmonics are
lines of known amplitude at exact HSS and mesh orders."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import xarray as xr
from harmonic_sweeps import HSS_LINES, MESH_LINES
from scipy import signal

import gbpipe.harmonics.comparison as comparison
import gbpipe.harmonics.removal as removal
from gbpipe.harmonics import (
    compare_method,
    method_params,
    method_residuals,
    removal_rows,
    split_residuals,
)
from gbpipe.io import mean_shaft_frequency

SPEC = {"signal": "torque_meter_driven_measured", "metric_rpm_bins": 4,
        "mode_half_width": 4.0, "mode_max_frequency": 400.0, "max_frequency": 700.0}


def _records(sw: dict) -> tuple[xr.Dataset, xr.Dataset, xr.Dataset]:
    """The sweep, its random-only twin and a bench dataset holding the 62 Hz mode."""
    attrs = {"sample_rate": sw["fs"], "pulses_per_rev": 1}
    units = {"units": "N m", "long_name": "GB1 torque meter, measured-like"}

    def record(x: np.ndarray) -> xr.Dataset:
        return xr.Dataset({SPEC["signal"]: ("time", x, units),
                           "pulse_time": ("pulse", sw["pulses"], {"units": "s"})},
                          coords={"time": ("time", sw["t"], {"units": "s"})}, attrs=attrs)

    bench = xr.Dataset({"closed_mode_frequency": ("closed_mode", [1.0, 62.0, 900.0]),
                        "closed_mode_damping": ("closed_mode", [0.1, 0.02, 0.05])})
    return record(sw["x"]), record(sw["res"]), bench


def _families(sw: dict) -> dict:
    return {"shaft": [k for k, _, _ in HSS_LINES],
            "mesh": [k * sw["mesh_order"] for k, _, _ in MESH_LINES]}


@pytest.fixture(scope="module")
def scored(sw):
    sweep, rnd, bench = _records(sw)
    return compare_method(sweep, rnd, bench, "regression", {"knot_spacing": 1.0},
                          _families(sw), SPEC)


def test_metric_reads_the_known_parts(scored, sw):
    # the harmonic part is exactly sweep - random-only: the regression leaves <= -60 dB of
    # it, and the broadband error it makes in the 62 Hz band is what it takes of the known
    # resonance response (a few per cent: small and negative, never a gain)
    assert float(scored.leftover_db.min()) >= 60.0
    band = scored.change_db.sel(band=[b for b in scored.band.values if b != "elsewhere"][0])
    assert np.all(band.values < 0.05) and np.all(band.values > -1.0)
    assert list(scored.band.values) == ["mode_62.0Hz", "elsewhere"]  # 1 and 900 Hz: outside
    # the residual on the time axis is the sweep minus the fitted harmonics
    err = scored.residual.values - sw["res"]
    inside = (sw["t"] > sw["pulses"][1]) & (sw["t"] < sw["pulses"][-2])
    assert np.std(err[inside]) < 0.2 * np.std(sw["res"])
    # what was run, and nothing that changes from run to run (wall time, memory)
    assert scored.attrs == {"method": "regression", "params": repr({"knot_spacing": 1.0}),
                            "families": "shaft mesh", "signal": SPEC["signal"]}


def test_rows_hold_every_method_family_bin_and_band(scored):
    rows = removal_rows([scored])
    assert len(rows) == 2 * 4 * 2  # families x rpm bins x bands
    for r in rows:
        assert r["attenuation_db"] == pytest.approx(
            float(scored.attenuation_db.sel(family=r["family"], rpm=r["rpm"])))
        assert r["change_db"] == pytest.approx(
            float(scored.change_db.sel(band=r["band"], rpm=r["rpm"])))
        assert r["rpm_lower"] < r["rpm"] < r["rpm_upper"]


def test_rows_name_the_order_and_mode_of_every_half_power_crossing(scored, sw):
    # independent: each order's frequency on a dense rpm grid of the bin, against the
    # 62 Hz mode's half-power band 62 (1 +- 0.02) Hz
    rows = [r for r in removal_rows([scored]) if r["band"] == "mode_62.0Hz"]
    fams = _families(sw)
    marked = 0
    for r in rows:
        f = np.linspace(r["rpm_lower"], r["rpm_upper"], 2001)[:, None] / 60.0 * np.sort(
            np.asarray(fams[r["family"]], dtype=float))[None, :]
        inside = ((f >= 62.0 * 0.98) & (f <= 62.0 * 1.02)).any(axis=0)
        if inside.any():
            marked += 1
            assert r["crossing_order"] == pytest.approx(np.sort(fams[r["family"]])[inside][0])
            assert r["crossing_mode"] == 62.0
        else:
            assert np.isnan(r["crossing_order"]) and np.isnan(r["crossing_mode"])
    assert marked >= 1  # the synthetic sweep takes an order through the mode


def test_a_different_random_only_record_is_refused(sw):
    sweep, rnd, bench = _records(sw)
    with pytest.raises(Exception, match="random-only sweep"):
        compare_method(sweep, rnd.isel(time=slice(0, 1000)), bench, "vkf", {},
                       _families(sw), SPEC)


def test_method_params_keep_the_families_at_hand():
    cfg = {"regression": {"knot_spacing": {"default": 1.0, "shaft": 2.0, "mesh1": 2.0}}}
    got = method_params(cfg, "regression", {"shaft": [1.0], "mesh2": [5.3]})
    assert got["knot_spacing"] == {"default": 1.0, "shaft": 2.0}


def test_modal_envelope_needs_and_passes_the_bench_modes():
    cfg = {"regression": {"knot_spacing": 2.0, "modal_envelope": True}}
    with pytest.raises(ValueError, match="bench modes"):
        method_params(cfg, "regression", {"shaft": [1.0]})
    got = method_params(cfg, "regression", {"shaft": [1.0], "motor": [12.0]},
                        np.array([[62.0, 0.02]]))
    assert "modal_envelope" not in got
    assert got["modal_families"] == ["shaft"]  # the pulsating torque follows the load
    np.testing.assert_array_equal(got["modes"], [[62.0, 0.02]])


@pytest.mark.parametrize("spacing, carried", [
    ({"default": 2.0, "motor": 1.0}, ["shaft", "mesh1"]),   # the coarsest group: all gears
    ({"default": 1.0, "shaft": 2.0}, ["shaft"]),            # only the 2 s group
    ({"default": 1.0, "motor": 2.0}, []),                   # the last group is the motor's
])
def test_modal_carriers_only_in_the_coarsest_knot_group(spacing, carried):
    """An earlier (finer) knot group's carriers would meet the later groups' lines
    unfitted: only the families of the largest spacing get carriers (never ``motor``)."""
    families = {"shaft": [1.0], "mesh1": [1.8], "motor": [12.0]}
    cfg = {"regression": {"knot_spacing": spacing, "modal_envelope": True}}
    got = method_params(cfg, "regression", families, np.array([[62.0, 0.02]]))
    largest = max(spacing.get(f, spacing["default"]) for f in families)
    assert all(spacing.get(f, spacing["default"]) == largest for f in got["modal_families"])
    assert got["modal_families"] == carried


def test_method_residuals_keep_the_low_part_and_remove_the_lines(sw):
    # a test record: a slow step (far below the lowest order's frequency) under the lines;
    # the split adds the low part back unchanged, so only the lines go
    step = 50.0 * (sw["t"] > 10.0)
    x = sw["hss"] + sw["mesh"] + step
    attrs = {"sample_rate": sw["fs"], "pulses_per_rev": 1, "test": "speed_up",
             "profile": "square"}
    rec = xr.Dataset({"motor_torque_driver_measured": ("time", x, {"units": "N m"}),
                      "pulse_time": ("pulse", sw["pulses"], {"units": "s"})},
                     coords={"time": ("time", sw["t"], {"units": "s"})}, attrs=attrs)
    out = method_residuals(rec, ["motor_torque_driver"], "regression", {"knot_spacing": 1.0},
                           _families(sw), keep_below=0.5)
    r = out.motor_torque_driver.values
    inside = (sw["t"] > sw["pulses"][2]) & (sw["t"] < sw["pulses"][-3])
    lines = np.mean((sw["hss"] + sw["mesh"])[inside] ** 2)
    # past the step's edge (the low-pass split smears it over ~1 s), and where the
    # lowest line is >= 1.5x the split frequency (0.5 x order 1 x the record's mean speed:
    # early in this sweep order 1 sits right at it and stays partly in the low part)
    calm = inside & (sw["t"] > 20.0)
    assert 10 * np.log10(lines / np.mean((r - step)[calm] ** 2)) >= 40.0
    assert out.attrs["method"] == "regression"
    # with a second record of the same angle (its harmonic part, as removal_tests pairs
    # them) in one call: each record's signals are those of its own call, bit for bit
    part = rec.assign(motor_torque_driver_measured=rec.motor_torque_driver_measured - step)
    both = method_residuals([rec, part], ["motor_torque_driver"], "regression",
                            {"knot_spacing": 1.0}, _families(sw), keep_below=0.5)
    alone = method_residuals(part, ["motor_torque_driver"], "regression",
                             {"knot_spacing": 1.0}, _families(sw), keep_below=0.5)
    np.testing.assert_array_equal(both[0].motor_torque_driver.values, r)
    np.testing.assert_array_equal(both[1].motor_torque_driver.values,
                                  alone.motor_torque_driver.values)


def test_a_long_records_channels_go_in_groups_each_as_alone(sw, monkeypatch):
    # a record too long for its channels' array in one call (GROUP_BYTES, here set to
    # two channels' worth) is removed two channels and then one: every channel's
    # residual is the one of all channels in one call, to the BLAS order's rounding, and
    # the result holds the channels in their order with their units
    rng = np.random.default_rng(11)
    lines = sw["hss"] + sw["mesh"]
    channels = {"a": lines, "b": lines + 0.3 * rng.standard_normal(lines.size),
                "c": -40.0 * lines}
    attrs = {"sample_rate": sw["fs"], "pulses_per_rev": 1}
    rec = xr.Dataset({f"{k}_measured": ("time", v, {"units": f"{k} unit"})
                      for k, v in channels.items()}
                     | {"pulse_time": ("pulse", sw["pulses"], {"units": "s"})},
                     coords={"time": ("time", sw["t"], {"units": "s"})}, attrs=attrs)
    args = (list(channels), "regression", {"knot_spacing": 1.0}, _families(sw), 0.5)
    whole = method_residuals(rec, *args)
    monkeypatch.setattr(removal, "GROUP_BYTES", 2 * 8 * rec.sizes["time"])
    assert removal.channel_groups("regression", list(channels), rec.sizes["time"]) == [
        ["a", "b"], ["c"]]
    calls = []

    def recorded(record, group, *rest):
        calls.append(list(group))
        return split_residuals(record, group, *rest)
    monkeypatch.setattr(comparison, "split_residuals", recorded)
    grouped = method_residuals(rec, *args)
    assert calls == [["a", "b"], ["c"]]  # the record's channels went in those groups
    assert list(grouped.data_vars) == ["a", "b", "c"]
    for k, v in channels.items():
        assert grouped[k].attrs["units"] == f"{k} unit"
        np.testing.assert_allclose(grouped[k].values, whole[k].values, rtol=0,
                                   atol=1e-11 * np.max(np.abs(v)))


def test_a_records_channels_are_held_once_while_the_regression_removes_them(sw):
    # split_residuals' array of the channels is the regression's input and output
    # (overwrite_x), the low part filtered again rather than kept: numpy's allocations
    # (traced by tracemalloc) peak at the channels' one array plus the regression's work
    # on one piece -- not three arrays (signals, low parts, residuals), nor a list of the
    # channels beside their array. The channels are float32, as a written record's
    # measured series: the residuals are bit for bit those of the split done the old way
    # (the low part kept from the float64 signal, added to the residual of the rest)
    rng = np.random.default_rng(12)
    lines = sw["hss"] + sw["mesh"]
    k, n = 12, sw["t"].size
    channels = {f"s{j}": ((1 + j) * lines + 0.3 * rng.standard_normal(n)).astype(np.float32)
                for j in range(k)}
    rec = xr.Dataset({f"{c}_measured": ("time", v, {"units": "N m"})
                      for c, v in channels.items()}
                     | {"pulse_time": ("pulse", sw["pulses"], {"units": "s"})},
                     coords={"time": ("time", sw["t"], {"units": "s"})},
                     attrs={"sample_rate": sw["fs"], "pulses_per_rev": 1})
    piece = n // 8  # the regression's pieces: its work is of one piece
    args = (list(channels), "regression", {"knot_spacing": 1.0, "piece": piece},
            _families(sw), 0.5)
    tracemalloc.start()
    held = method_residuals(rec, *args)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    one = 8 * n * k  # bytes of the channels' array
    assert peak < 1.75 * one, (peak / one)

    lowest = min(min(o) for o in _families(sw).values())
    sos = signal.butter(6, 0.5 * lowest * mean_shaft_frequency(rec), fs=sw["fs"], output="sos")
    x = np.column_stack([v.astype(float) for v in channels.values()])
    low = np.column_stack([signal.sosfiltfilt(sos, c) for c in x.T])
    old = low + removal.remove_harmonics("regression", x - low, sw["fs"], sw["pulses"],
                                         _families(sw), 1, knot_spacing=1.0, piece=piece)
    for j, c in enumerate(channels):
        np.testing.assert_array_equal(held[c].values, old[:, j])
