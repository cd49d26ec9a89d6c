"""config/examples/measured.yaml end to end, on bench files the tests write.

The files hold a simulated test record as a bench would log it (two CSV files, one with
jittered time stamps and an encoder angle in degrees, a TDMS file with the torque meter in
kN*m and an analog tacho): `tests/measured/bench_campaign.py`. What the workflow reads
back, and what it identifies, is checked against that record and the bench model, both
independent of the reading and identification code.
"""

from __future__ import annotations

import copy
import csv
from pathlib import Path

import numpy as np
import yaml
from scipy.integrate import cumulative_trapezoid

from gbpipe import io
from gbpipe.harmonics import order_amplitudes
from gbpipe.identify import decimate
from gbpipe.kinematics import mesh_names, order_of
from gbpipe.lti import frf
from gbpipe.model.truth import truth_model
from tests.measured.bench_campaign import write_campaign_files
from tests.workflow.runs import MEASURED_CONFIGS, copy_repo, snakemake

#: Bench signal -> the simulated signal its file encodes.
TRUE_NAME = {"torque_meter": "torque_meter_driving", "speed_motor": "speed_gb2_hss"}


def test_record_reads_back_the_files(measured_run):
    work, truth = measured_run
    rec = io.read(work / "results" / "measured" / "run12.nc")
    sim = truth["record"]
    assert rec.attrs["record_kind"] == "measured" and rec.sizes["time"] == sim.sizes["time"]
    assert rec.torque_meter.attrs["units"] == "N m"  # kN*m in the file, SI in the record
    # CSV (12 significant digits) and TDMS hold the torques exactly on the record's grid
    for name in ("motor_torque_driver", "motor_torque_driven", "torque_meter"):
        want = truth["signals"][name]
        assert np.max(np.abs(rec[name].values - want)) <= 1e-9 * np.max(np.abs(want)), name
    # the encoder angle (deg, jittered clock) differentiated back to speed: equal to the
    # logged speed in the identified band (decimated to 1 kHz, 400 Hz pass band)
    fs = float(rec.attrs["sample_rate"])
    got = decimate(rec.speed_motor.values, fs, 1000.0)
    want = decimate(truth["signals"]["speed_motor"], fs, 1000.0)
    ac = want - want.mean()
    assert np.sqrt(np.mean((got - want) ** 2)) < 0.02 * np.sqrt(np.mean(ac**2))
    # the tacho's rising mid-level crossings are where the GB1 HSS angle passes the
    # generator's phase: computed here from the simulated speed, independently
    t = sim.time.values
    theta = cumulative_trapezoid(sim.speed_gb1_hss.values, t, initial=0.0) + 0.3
    k = np.arange(np.ceil(theta[0] / (2 * np.pi)), np.floor(theta[-1] / (2 * np.pi)) + 1)
    expected = np.interp(2 * np.pi * k, theta, t)
    pulses = rec.pulse_time.values
    assert pulses.size == expected.size
    assert np.max(np.abs(pulses - expected)) < 2e-6  # s: 1 % of a sample at 5 kHz


def test_order_spectrum_shows_the_gear_meshes(measured_run):
    # the mesh orders of the configured gearbox that the spectrum resolves (above 2) stand
    # >= 15 dB above the order spectrum around them (0.2 to 1 order away)
    work, truth = measured_run
    sp = io.read(work / "results" / "spectra" / "measured" / "run12.nc")
    power = np.nanmean(sp.order_power.values, axis=0)
    order = sp.order.values
    stages = truth["cfg"]["gearbox"]["stages"]
    checked = 0
    for mesh in mesh_names(len(stages)):
        m = float(order_of(stages, mesh))
        if not 2.0 < m < order[-1] - 1.0:
            continue
        around = (np.abs(order - m) > 0.2) & (np.abs(order - m) < 1.0)
        line = power[np.argmin(np.abs(order - m))]
        assert 10 * np.log10(line / np.median(power[around])) >= 15.0, mesh
        checked += 1
    assert checked >= 1


def test_tsa_removes_the_families_from_the_bench_record(measured_run):
    # the removed cycles' harmonics fall by >= 20 dB in the order spectrum of the residual
    work, truth = measured_run
    rec = io.read(work / "results" / "measured" / "run12.nc")
    tsa = io.read(work / "results" / "tsa" / "measured" / "run12.nc")
    cfg = truth["cfg"]
    fs, ppr = float(rec.attrs["sample_rate"]), int(rec.attrs["pulses_per_rev"])
    for cyc in cfg["tsa"]["tests"]:
        c = float(order_of(cfg["gearbox"]["stages"], cyc))
        orders = c * np.arange(1, 4)
        before = order_amplitudes(rec.torque_meter.values, fs, rec.pulse_time.values, orders,
                                  pulses_per_rev=ppr)
        after = order_amplitudes(tsa.torque_meter.values, fs, rec.pulse_time.values, orders,
                                 pulses_per_rev=ppr)
        drop = 20 * np.log10(np.abs(before).max() / np.abs(after).max())
        assert drop >= 20.0, (cyc, drop)


def test_nonparametric_reference_agrees_with_the_bench_model(measured_run):
    # No truth enters the identify stage; here the bench model says what the data should
    # give. H1 in closed loop is biased where feedback correlates input and noise, so the
    # check is loose but physical: at the coherent frequencies of the raw data the
    # estimate is within 0.5 dB of the model (median) and its 95 % band holds the model at
    # >= 75 % of them.
    work, truth = measured_run
    ds = io.read(work / "results" / "identify" / "measured" / "run12_pbsid.nc")
    assert ds.attrs["reference"] == "nonparametric"
    f = ds.frequency.values
    for k in np.flatnonzero(ds.version.values == "raw"):
        sel = ds.isel(model=int(k))
        out = TRUE_NAME[str(sel.output_name.values[0])]
        g = frf(truth_model(truth["cfg"], ["motor_torque_driver"], [out]), f)[:, 0, 0]
        ref = (sel.frf_reference_real + 1j * sel.frf_reference_imag).values[:, 0, 0]
        ok = sel.assessable.values > 0.5
        assert ok.sum() >= 20
        err = np.abs(20 * np.log10(np.abs(ref[ok]) / np.abs(g[ok])))
        inside = ((np.abs(g) >= sel.frf_reference_lower.values[:, 0, 0])
                  & (np.abs(g) <= sel.frf_reference_upper.values[:, 0, 0]))[ok]
        assert np.median(err) <= 0.5 and inside.mean() >= 0.75, (out, np.median(err),
                                                                 inside.mean())


def test_table_scores_each_model_against_the_data(measured_run):
    # every row says what it was measured against; its share within tolerance is
    # recomputed from the stored FRFs and bounds
    work, truth = measured_run
    with open(work / "results" / "tables" / "identification_measured.csv") as fh:
        rows = list(csv.DictReader(fh))
    idc = truth["cfg"]["identify"]
    assert len(rows) == len(idc["methods"]) * len(idc["pairings"]) * len(idc["versions"])
    assert {r["reference"] for r in rows} == {"nonparametric"}
    for method in idc["methods"]:
        ds = io.read(work / "results" / "identify" / "measured" / f"run12_{method}.nc")
        tol = ds.attrs["tolerance_db"]
        for k in range(ds.sizes["model"]):
            sel = ds.isel(model=k)
            g = np.abs(sel.frf_identified_real + 1j * sel.frf_identified_imag).values[:, 0, 0]
            ref = np.abs(sel.frf_reference_real + 1j * sel.frf_reference_imag).values[:, 0, 0]
            lo, hi = sel.frf_reference_lower.values[:, 0, 0], sel.frf_reference_upper.values[
                :, 0, 0]
            ok = sel.assessable.values > 0.5
            good = (np.abs(20 * np.log10(g / ref)) <= tol) | ((g >= lo) & (g <= hi))
            row = next(r for r in rows if r["method"] == method
                       and r["pairing"] == str(sel.pairing.values)
                       and r["version"] == str(sel.version.values))
            assert float(row["within_tol_pct"]) == np.float64(100 * good[ok].mean())


def _bad_copy(tmp_path, measured_run, change: dict | None = None) -> Path:
    # a fresh copy with the example's bench files and an overlay that changes the mapping
    work = copy_repo(tmp_path)
    write_campaign_files(measured_run[1]["record"], work / "bench")
    spec = copy.deepcopy(measured_run[1]["cfg"]["measured"])
    for key, value in (change or {}).items():
        node = spec["run12"]
        *path, last = key.split(".")
        for k in path:
            node = node[k]
        node[last] = value
    (work / "bad.yaml").write_text(yaml.safe_dump({"measured": spec}))
    return work


def _fails_cleanly(work: Path, *names: str, target: str = "results/measured/run12.nc"):
    proc = snakemake(work, target, "--configfile", *MEASURED_CONFIGS, "bad.yaml", check=False)
    assert proc.returncode != 0
    for name in names:
        assert name in proc.stderr, (name, proc.stderr[-3000:])
    written = [p for p in (work / "results").rglob("*") if p.is_file()
               and p.suffix in (".nc", ".csv", ".png")] if (work / "results").exists() else []
    assert not written, written


def test_mapping_typo_is_refused_at_load(tmp_path, measured_run):
    work = _bad_copy(tmp_path, measured_run, {
        "signals.torque_meter": {"file": "daq", "chanel": "Measurements/Torque"}})
    _fails_cleanly(work, "measured.run12.signals.torque_meter.chanel", "did you mean 'channel'")
    assert not (work / "results").exists()  # refused before any job


def test_missing_channel_and_nan_fail_the_job_and_write_nothing(tmp_path, measured_run):
    work = _bad_copy(tmp_path, measured_run, {
        "signals.torque_meter": {"file": "daq", "channel": "Measurements/Torq"}})
    _fails_cleanly(work, "bench/run12.tdms", "Measurements/Torq", "Measurements/Torque")
    # a NaN in row 1234 of the motors file: named by file, channel and sample
    work = _bad_copy(tmp_path / "nan", measured_run)
    motors = work / "bench" / "run12_motors.csv"
    lines = motors.read_text().splitlines()
    cells = lines[1235].split(",")
    lines[1235] = ",".join([cells[0], "nan", *cells[2:]])
    motors.write_text("\n".join(lines) + "\n")
    _fails_cleanly(work, "run12_motors.csv", "drive torque", "1234")
