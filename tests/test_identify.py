"""Identification stage: truth model, conditioning, metrics and the table's provenance."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe.identify import metrics

FS = 5000.0


def _direct(A, B, C, f):
    """C (jωI − A)⁻¹ B by one linear solve per frequency (no eigen-decomposition)."""
    eye = np.eye(A.shape[0])
    return np.array([C @ np.linalg.solve(2j * np.pi * fk * eye - A, B) for fk in f])


def test_truth_driver_torque_closes_only_the_torque_loop(cfg):
    # Independent construction: open-loop plant from both motor torques to the speed and the
    # driven torque meter, then the braking-torque PI closed by hand in the frequency domain:
    # T_brake = -(kp + ki/s) M  =>  w/T_drv = P_wd - P_wb C P_Md / (1 + P_Mb C).
    from gbpipe.identify import truth_frf, truth_model
    from gbpipe.model import bench_ss, frf

    f = np.geomspace(0.5, 400, 60)
    p = bench_ss(cfg, closed=False).select(
        ["motor_torque_driver", "motor_torque_driven"], ["speed_gb1_hss", "torque_meter_driven"])
    P = _direct(p.A, p.B, p.C, f)
    tc = cfg["bench"]["torque_controller"]
    Cq = float(tc["kp"]) + float(tc["ki"]) / (2j * np.pi * f)
    expect = P[:, 0, 0] - P[:, 0, 1] * Cq * P[:, 1, 0] / (1 + P[:, 1, 1] * Cq)
    got = truth_frf(truth_model(cfg, ["motor_torque_driver"], ["speed_gb1_hss"]), f)[:, 0, 0]
    np.testing.assert_allclose(got, expect, rtol=1e-6)
    # the modal shortcut agrees where the path is not a deep cancellation
    big = np.abs(expect) > 1e-3 * np.abs(expect).max()
    np.testing.assert_allclose(frf(truth_model(cfg, ["motor_torque_driver"], ["speed_gb1_hss"]),
                                   f)[big, 0, 0], expect[big], rtol=1e-3)


def test_truth_driven_torque_closes_only_the_speed_loop(cfg):
    # Speed PI on the driver-motor speed: T_drv = -(kp + ki/s) w_motor (the set-point weight
    # acts on the reference only). Braking torque enters the plant with a minus sign.
    from gbpipe.identify import truth_frf, truth_model
    from gbpipe.model import bench_ss

    f = np.geomspace(0.5, 400, 60)
    p = bench_ss(cfg, closed=False).select(
        ["motor_torque_driver", "motor_torque_driven"], ["speed_gb2_hss", "speed_driver_motor"])
    P = _direct(p.A, p.B, p.C, f)
    sc = cfg["bench"]["speed_controller"]
    Cw = float(sc["kp"]) + float(sc["ki"]) / (2j * np.pi * f)
    expect = P[:, 0, 1] - P[:, 0, 0] * Cw * P[:, 1, 1] / (1 + P[:, 1, 0] * Cw)
    got = truth_frf(truth_model(cfg, ["motor_torque_driven"], ["speed_gb2_hss"]), f)[:, 0, 0]
    np.testing.assert_allclose(got, expect, rtol=1e-5)


def test_truth_mimo_is_the_open_loop_plant_with_a_rigid_body_pole(cfg):
    from gbpipe.identify import truth_model

    ins = ["motor_torque_driver", "motor_torque_driven"]
    t = truth_model(cfg, ins, ["speed_gb2_hss", "speed_gb1_hss"])
    f = np.array([0.01, 0.02])
    G = _direct(t.A, t.B, t.C, f)
    # rigid body: |G| ~ 1/(J_total ω) at very low frequency, and braking opposes driving
    ratio = np.abs(G[0]) / np.abs(G[1])
    np.testing.assert_allclose(ratio, 2.0, rtol=0.02)
    assert np.all(np.sign(G[:, :, 0].imag) == -np.sign(G[:, :, 1].imag))
    with pytest.raises(ValueError, match="motor_torque"):
        truth_model(cfg, ["torque_meter_driven"], ["speed_gb1_hss"])


def test_decimation_keeps_the_band_and_rejects_aliases():
    from gbpipe.identify import decimate

    t = np.arange(int(4 * FS)) / FS
    inband = np.sin(2 * np.pi * 120.0 * t)
    alias = np.sin(2 * np.pi * 880.0 * t)  # would fold onto 120 Hz at 1 kHz
    y_in = decimate(inband, FS, 1000.0)
    y_al = decimate(alias, FS, 1000.0)
    assert abs(np.std(y_in) - np.std(inband)) < 0.01 * np.std(inband)
    assert np.std(y_al) < 1e-3 * np.std(alias)
    # same filter on every channel: the ratio of two channels' spectra is unchanged
    x = np.random.default_rng(1).standard_normal((int(2 * FS), 2))
    x[:, 1] = 3 * x[:, 0]
    y = decimate(x, FS, 1000.0)
    np.testing.assert_allclose(y[:, 1], 3 * y[:, 0], rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="integer"):
        decimate(x, FS, 1300.0)


def test_condition_removes_the_operating_point_not_the_record_mean():
    from gbpipe.identify import condition

    x = np.full(int(10 * FS), 117.0)
    x[int(4 * FS):] += 5.0  # a speed step after the settle time
    y = condition([x], FS, 2.0, 1000.0)
    assert abs(y[10, 0]) < 1e-9 and abs(y[-1, 0] - 5.0) < 1e-9


def test_match_bandwidth_definition():
    f = np.array([5.0, 10, 20, 40, 80])
    assert metrics.match_bandwidth(f, np.array([0.1, -0.5, 0.9, 1.5, 0.0])) == 20.0
    assert metrics.match_bandwidth(f, np.array([2.0, 0, 0, 0, 0])) == 0.0
    assert metrics.match_bandwidth(f, np.zeros(5)) == 80.0
    two = np.zeros((5, 2, 2))
    two[3, 1, 0] = -1.2  # one MIMO element failing counts
    assert metrics.match_bandwidth(f, two) == 20.0


def test_reflection_keeps_the_in_band_magnitude():
    from gbpipe.identify.stage import reflect_out_of_band
    from gbpipe.sysid import SubspaceModel

    # lightly damped mode at 100 Hz plus a spurious unstable real pole at z = -1.07
    dt = 1e-3
    r = np.exp(-0.02 * 2 * np.pi * 100 * dt)
    th = 2 * np.pi * 100 * dt
    A = np.array([[r * np.cos(th), -r * np.sin(th), 0], [r * np.sin(th), r * np.cos(th), 0],
                  [0, 0, -1.07]])
    B = np.array([[1.0], [0.5], [0.3]])
    C = np.array([[1.0, 0.2, 1.0]])
    m = SubspaceModel(A, B, C, np.zeros((1, 1)), np.zeros((3, 1)), np.eye(1), np.ones(3), dt,
                      "pbsid", 3)
    m2 = reflect_out_of_band(m, 400.0)
    assert np.all(np.abs(np.linalg.eigvals(m2.A)) < 1)
    f = np.geomspace(5, 350, 50)
    g1, g2 = np.abs(m.frf(f)), np.abs(m2.frf(f))
    # only the phase of the Nyquist term changes: magnitude within a few % in the band
    np.testing.assert_allclose(g2, g1, rtol=0.1)
    np.testing.assert_allclose(m2.frf([100.0]), m.frf([100.0]), rtol=0.02)


def test_tsa_removes_a_locked_harmonic_and_keeps_the_step(cfg):
    # constant-speed HSS at 18 Hz, 3rd order harmonic + a torque step: TSA of hss + mesh2
    # must remove the harmonic and keep the step (split below the lowest cycle frequency)
    from gbpipe.identify.prepare import tsa_residuals

    fs, T, f0 = FS, 12.0, 18.0
    t = np.arange(int(T * fs)) / fs
    theta = 2 * np.pi * f0 * t
    step = np.where((t > 4) & (t < 8), 100.0, 0.0)
    harm = 50.0 * np.sin(3 * theta + 0.3)
    pulses = np.arange(1, int(T * f0) - 1) / f0
    ds = xr.Dataset({"x_measured": ("time", step + harm),
                     "speed_gb1_hss": ("time", np.full(t.size, 2 * np.pi * f0)),
                     "pulse_time": ("pulse", pulses)}, coords={"time": t},
                    attrs={"sample_rate": fs, "pulses_per_rev": 1})
    r = tsa_residuals(ds, ["x"], cfg["gearbox"]["stages"], cfg["tsa"], 0.5)["x"]
    inner = (t > 1) & (t < T - 1) & (np.abs(t - 4) > 0.3) & (np.abs(t - 8) > 0.3)
    assert np.std((r - step)[inner]) < 0.05 * np.std(harm)


@pytest.fixture(scope="module")
def synthetic_job(cfg, tmp_path_factory):
    """A stored identification job on synthetic records from the true open-loop plant."""
    from scipy import signal

    from gbpipe import io
    from gbpipe.identify import identify_record, truth_model

    ins = ["motor_torque_driver", "motor_torque_driven"]
    outs = ["speed_gb2_hss", "speed_gb1_hss"]
    t_ss = truth_model(cfg, ins, outs)
    sysd = signal.cont2discrete((t_ss.A, t_ss.B, t_ss.C, t_ss.D), 1 / FS)
    n = int(8 * FS)

    def record(seed, test):
        rng = np.random.default_rng(seed)
        u = 150.0 * rng.standard_normal((n, 2))
        u[: int(FS)] = 0.0  # 1 s at the operating point
        _, y, _ = signal.dlsim(signal.dlti(*sysd[:4], dt=1 / FS), u)
        ds = xr.Dataset(coords={"time": np.arange(n) / FS},
                        attrs={"sample_rate": FS, "test": test, "profile": "square"})
        for k, name in enumerate(ins):
            ds[name] = ("time", u[:, k] + 16250.0)
            ds[f"{name}_measured"] = ("time", u[:, k] + 16250.0 + rng.standard_normal(n))
        for k, name in enumerate(outs):
            ds[name] = ("time", y[:, k] + 117.0)
            ds[f"{name}_measured"] = ("time", y[:, k] + 117.0 + 1e-5 * rng.standard_normal(n))
        return ds

    rec, val = record(1, "speed_up"), record(2, "speed_down")
    c = dict(cfg)
    c["campaign"] = {**cfg["campaign"], "settle": 1.0}
    c["identify"] = {**cfg["identify"], "versions": ["clean", "raw"], "past": 60, "future": 30,
                     "frf": {"f_min": 5.0, "f_max": 300.0, "points": 80},
                     "pairings": [p for p in cfg["identify"]["pairings"]
                                  if p["name"] in ("Tdrv_to_wdrv", "mimo")]}
    ds = identify_record(c, rec, val, "pbsid")
    path = tmp_path_factory.mktemp("identify") / "job.nc"
    io.write(ds, path, stage="identify", config=c["identify"])
    return c, io.read(path), rec, val


def test_table_numbers_come_from_the_stored_models(synthetic_job):
    from gbpipe.identify import condition, model_matrices, table_rows, truth_model
    from gbpipe.identify.prepare import version_signals
    from gbpipe.identify.stage import validation_fit
    from gbpipe.sysid import SubspaceModel

    c, ds, rec, val = synthetic_job
    rows = table_rows([ds])
    assert len(rows) == 4
    dt = float(ds.sample_time)
    f = ds.frequency.values
    pairings = {p["name"]: p for p in c["identify"]["pairings"]}
    for row in rows:
        key = f"{row['pairing']}/{row['version']}"
        A, B, C, D = model_matrices(ds, key)
        p = pairings[row["pairing"]]
        g_id = np.array([C @ np.linalg.solve(np.exp(2j * np.pi * fk * dt) * np.eye(len(A)) - A,
                                             B) + D for fk in f])
        g_true = _direct(*(lambda t: (t.A, t.B, t.C))(truth_model(c, p["inputs"], p["outputs"])),
                         f)
        bw = metrics.match_bandwidth(f, metrics.frf_error_db(g_id, g_true), 1.0)
        assert row["match_bandwidth_hz"] == pytest.approx(bw)
        m = SubspaceModel(A, B, C, D, np.zeros((len(A), C.shape[0])), np.eye(C.shape[0]),
                          np.ones(1), dt, "pbsid", len(A))
        uv = condition(version_signals(val, p["inputs"], row["version"]), FS, 1.0, 1000.0)
        yv = condition(version_signals(val, p["outputs"], row["version"]), FS, 1.0, 1000.0)
        fit = validation_fit(m, uv, yv, 2000)
        assert row["fit_pct"] == pytest.approx(float(np.mean(fit)), abs=1e-6)


def test_open_loop_noise_free_mimo_matches_the_direct_paths(synthetic_job):
    # open-loop white torques, no noise: each torque -> its own HSS speed must match far up;
    # the cross paths (45 dB weaker, behind the 1.2 Hz motor-against-motor mode) need not
    from gbpipe.identify import table_rows

    rows = {(r["pairing"], r["version"]): r for r in table_rows([synthetic_job[1]])}
    elem = dict(e.split(":") for e in rows[("mimo", "clean")]["element_bandwidth_hz"].split(";"))
    assert float(elem["wdrv<-Tdrv"]) >= 100.0 and float(elem["wdrn<-Tdrn"]) >= 100.0
    assert rows[("mimo", "clean")]["fit_pct"] > 95.0
