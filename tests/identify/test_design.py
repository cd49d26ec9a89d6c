"""The design step's prediction against simulation and physics: coherence by Monte Carlo,
the 95 % magnitude-error bound, encoder quantisation noise, the gear-excitation lines of each
data version, and the bench cases."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy import signal

from gbpipe import identify, model
from gbpipe.identify.design import error_bound_db, pairing_prediction
from gbpipe.identify.spectra_model import (
    excitation_psds,
    quantised_speed_psd,
    reference_psd,
    white_psd,
)
from gbpipe.kinematics import order_of
from gbpipe.simulate import multisine
from gbpipe.simulate.profiles import step_reference


def _two_mass(fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Discrete (ZOH) torque -> speed of a lightly damped 2-mass system: modes at 0 Hz and
    ~60 Hz, damping ratio 0.03 (numerator, denominator of a transfer function in z)."""
    j1, j2, k = 2.0, 1.0, 1.0e5
    wn = np.sqrt(k * (j1 + j2) / (j1 * j2))
    c = 2 * 0.03 * wn * j1 * j2 / (j1 + j2)
    # states: twist angle, both speeds; a little viscous friction to ground (2 N·m·s/rad)
    # keeps the rigid-body pole inside the unit circle
    a = np.array([[0, 1, -1], [-k / j1, -(c + 2.0) / j1, c / j1], [k / j2, c / j2, -c / j2]])
    b, cc = np.array([[0], [1 / j1], [0]]), np.array([[0, 0, 1.0]])
    ad, bd, cd, dd, _ = signal.cont2discrete((a, b, cc, np.zeros((1, 1))), 1 / fs)
    num, den = signal.ss2tf(ad, bd, cd, dd)
    return np.ravel(num), den


def test_predicted_coherence_matches_monte_carlo_coherence():
    # u white (the reference), y = G u + white sensor noise: the measured coherence of
    # (u, y), averaged over 20 seeds, must equal |G|^2 Phi_u / (|G|^2 Phi_u + Phi_v)
    fs, n, su, sn = 1000.0, 2 ** 17, 3.0, 2.0e-3
    num, den = _two_mass(fs)
    f, est = None, []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        u = su * rng.standard_normal(n)
        y = signal.lfilter(num, den, u) + sn * rng.standard_normal(n)
        f, c = signal.coherence(u, y, fs=fs, nperseg=4096)
        est.append(c)
    band = (f >= 5.0) & (f <= 450.0)
    f = f[band]
    measured = np.mean(est, axis=0)[band]
    g = signal.freqz(num, den, worN=f, fs=fs)[1][:, None, None]
    res = pairing_prediction(np.ones((f.size, 1, 1)), g, g, white_psd(su, fs, f)[:, None],
                             np.zeros((f.size, 1)), white_psd(sn, fs, f)[:, None], 1e-3)
    predicted = res["coherence"][:, 0, 0]
    assert res["exciting"].tolist() == [True]
    # the test spans the whole range of coherence, not one end of it
    assert predicted.min() < 0.01 and predicted.max() > 0.98
    assert np.any((predicted > 0.3) & (predicted < 0.7))
    # Welch's coherence from n_d averages is biased up by (1 - g2)^2 / n_d (Bendat &
    # Piersol, Random Data, 4th ed., 2010, eq. 9.73); n_d = 63 segments of 4096 samples
    # (resolution 0.24 Hz, far below the 3.7 Hz half-power width of the resonance)
    expected = predicted + (1 - predicted) ** 2 / 63
    # seed scatter: a coherence near 0.3 from 63 averages has std ~0.1, ~0.02 over 20
    # seeds; a factor 2 in the predicted SNR moves 0.5 to 0.33 or 0.67
    mid = (predicted > 0.1) & (predicted < 0.9)
    assert mid.sum() > 50
    assert np.max(np.abs(measured - expected)) < 0.08
    assert abs(np.mean(measured[mid] - expected[mid])) < 0.005
    assert np.median(np.abs(measured - expected)) < 0.01


def test_error_bound_covers_95_percent_of_circular_gaussian_errors():
    rng = np.random.default_rng(3)
    for sigma in (0.01, 0.05):
        delta = sigma / np.sqrt(2) * (rng.standard_normal(200_000)
                                      + 1j * rng.standard_normal(200_000))
        err = np.abs(20 * np.log10(np.abs(1 + delta)))
        coverage = np.mean(err <= error_bound_db(sigma))
        assert 0.945 < coverage < 0.96
    assert np.isinf(error_bound_db(1.0))


def test_quantised_speed_psd_matches_a_differenced_encoder():
    fs, counts = 5000.0, 4096
    q = 2 * np.pi / counts
    t = np.arange(2 ** 17) / fs
    # vibration of a few counts makes the error of consecutive samples independent, the
    # formula's assumption (a perfectly steady angle gives a periodic error pattern)
    theta = 117.0 * t + 5 * q * np.random.default_rng(2).standard_normal(t.size)
    omega = np.diff(np.floor(theta / q) * q) * fs
    omega -= np.diff(theta) * fs                                 # the error alone
    f, p = signal.welch(omega, fs=fs, nperseg=4096)
    sel = (f > 100) & (f < 2400)
    ratio = p[sel] / quantised_speed_psd(f[sel], counts, fs)
    assert np.median(ratio) == pytest.approx(1.0, abs=0.05)


def test_reference_psd_of_white_noise_and_of_a_multisine():
    fs = 2000.0
    f = np.geomspace(5, 400, 50)
    x = 2.0 * np.random.default_rng(1).standard_normal(200_000)
    assert np.median(reference_psd(x, fs, f) / white_psd(2.0, fs, f)) == pytest.approx(
        1.0, abs=0.05)
    # a flat multisine of rms 3 over 10..200 Hz: 9 / 190 per Hz inside, ~0 outside
    ms = multisine(fs, 60.0, 10.0, 200.0, 3.0, frequency_resolution=0.1)
    p = reference_psd(ms, fs, f)
    inside, outside = (f > 12) & (f < 198), f > 205
    assert np.median(p[inside]) == pytest.approx(9.0 / 190.0, rel=0.05)
    assert np.all(p[outside] < 1e-6 * 9.0 / 190.0)


@pytest.fixture(scope="module")
def bench(cfg):
    c = copy.deepcopy(dict(cfg))
    quiet = {"broadband": 0.0, "pole_pairs": 2, "pulsating": []}
    c["noise"] = {"motor_ripple": {"driver": dict(quiet), "driven": dict(quiet)},
                  "sensor": {"speed": 0.002, "torque": 10.0},
                  "encoder": {"counts_per_rev": 8388608}}
    # no gear excitation either: the measured-like version holds the sensor noise alone
    c["excitation"] = {**c["excitation"], "gearboxes": []}
    c["identify"] = {**c["identify"], "versions": ["clean", "raw"], "pairings": [
        {"name": "Tdrv_to_wdrv", "inputs": ["motor_torque_driver"],
         "outputs": ["speed_gb2_hss"]},
        {"name": "Tdrn_to_Mdrn", "inputs": ["motor_torque_driven"],
         "outputs": ["torque_meter_driven"]}]}
    truths = {p["name"]: model.truth_model(c, p["inputs"], p["outputs"])
              for p in c["identify"]["pairings"]}
    return c, model.bench_ss(c), truths


def _torque_test(c, closed, truths, scale=1.0, version="raw"):
    """torque_up, tapered, with a 2 kN·m multisine 1-450 Hz on the torque set-point; the
    whole set-point times ``scale``; the prediction of one data version."""
    fs = float(c["campaign"]["sample_rate"])
    _, w, tq = step_reference(c["campaign"], "torque_up", "tapered")
    tq = tq + multisine(fs, w.size / fs, 1.0, 450.0, 2000.0, frequency_resolution=0.1)
    return identify.predict_test(c, closed, truths, w, scale * tq, fs).sel(version=version)


def test_pairing_without_excitation_predicts_zero_band(bench):
    c, closed, truths = bench
    # torque test, no ripple: nothing drives the driver's torque but feedback of the
    # disturbance, so its pairing is not identifiable; the driven one is, to high frequency
    ds = _torque_test(c, closed, truths)
    drv, drn = ds.sel(pairing="Tdrv_to_wdrv"), ds.sel(pairing="Tdrn_to_Mdrn")
    assert float(drv.predicted_hz) == 0.0
    assert int(drv.identifiable.sum()) == 0
    # the constant speed set-point leaves only round-off
    assert float(drv.input_psd.max()) < 1e-12 * float(drn.input_psd.max())
    assert float(drn.predicted_hz) > 100.0
    assert float(drn.excitation_share.sel(source="torque_ref")) > 0.99
    # without ripple, all the driven pairing cannot explain is sensor noise
    sensors = drn.disturbance_share.sel(term=["sensor_output", "sensor_input"]).sum("term")
    assert np.allclose(sensors.values[:, 0], 1.0, atol=1e-9)


def test_band_limited_excitation_gives_a_non_contiguous_mask():
    # a synthetic SISO pairing excited only in 100..200 Hz: the band from f_min is 0 Hz,
    # the mask shows the identifiable island
    f = np.geomspace(5, 350, 120)
    g = (1.0 / (2j * np.pi * f))[:, None, None]
    phi_r = np.where((f > 100) & (f < 200), 1.0, 0.0)
    ds = identify.predict(np.concatenate([np.ones((f.size, 1, 1)), g], axis=1), ["u", "y"],
                          ["r"], [{"name": "p", "inputs": ["u"], "outputs": ["y"]}],
                          {"p": g}, {"r": phi_r}, {"y": np.full(f.size, 1e-9)}, f, 10,
                          10_000, 1.0)
    mask = ds.identifiable.values[0].astype(bool)
    assert float(ds.predicted_hz[0]) == 0.0
    assert mask[(f > 101) & (f < 199)].all() and not mask[(f < 99) | (f > 201)].any()


def test_snr_scales_by_20_db_with_ten_times_the_excitation(bench):
    c, closed, truths = bench
    one, ten = (_torque_test(c, closed, truths, scale) for scale in (1.0, 10.0))
    d1, d10 = (d.sel(pairing="Tdrn_to_Mdrn") for d in (one, ten))
    inside = (one.frequency.values > 6) & (one.frequency.values < 440)
    diff = (d10.snr_db - d1.snr_db).values[inside, 0]
    assert np.allclose(diff, 20.0, atol=1e-6)
    # and the error bound follows sigma / 10 (small-error regime)
    e1, e10 = (d.predicted_error_db.values[inside, 0, 0] for d in (d1, d10))
    small = e1 < 0.1
    assert small.any()
    assert np.allclose(e10[small], e1[small] / 10, rtol=0.02)


def test_gear_excitation_lines_carry_their_power_where_they_sweep(cfg):
    # Parseval for each line: a sinusoid of amplitude a has power a^2 / 2; spread over the
    # frequencies o x [f_lo, f_hi] (+- half the resolution) it crosses. Independent of the
    # code: the integral of the PSD on a fine grid and the support from the orders.
    stages = cfg["gearbox"]["stages"]
    exc = {"gearboxes": ["gb1"], "shaft_orders": [{"order": 3, "amplitude": 4.0e-5}],
           "mesh": [{"stage": 2, "amplitude": 6.0e-5, "harmonics": [1.0, 0.4]}]}
    f = np.arange(0.0, 3000.0, 0.01)
    rot, load, res = (10.0, 12.0), 0.5, 1.0
    names = ["misalign_gb1_coupling", "te_gb1_mesh2", "te_gb2_mesh2"]
    psd = excitation_psds(exc, stages, names, f, rot, load, res)
    o2 = float(order_of(stages, "mesh2"))
    expect = {"misalign_gb1_coupling": ((4.0e-5 * load) ** 2 / 2, [3.0]),
              "te_gb1_mesh2": (((6.0e-5 * load) ** 2 + (0.4 * 6.0e-5 * load) ** 2) / 2,
                               [o2, 2 * o2])}
    for name, (power, orders) in expect.items():
        assert np.trapezoid(psd[name], f) == pytest.approx(power, rel=0.01)
        inside = np.zeros(f.size, dtype=bool)
        for o in orders:
            inside |= (f >= o * rot[0] - res / 2) & (f <= o * rot[1] + res / 2)
        assert np.all(psd[name][~inside] == 0.0) and np.all(psd[name][inside] > 0.0)
    assert not psd["te_gb2_mesh2"].any()  # gb2 carries no excitation here
    # a synchronous removal of the HSS takes off the whole-multiple HSS order 3, not the
    # mesh-2 lines (their order is no whole number); one of mesh 2 takes off those
    hss = excitation_psds(exc, stages, names, f, rot, load, res, [order_of(stages, "hss")])
    assert not hss["misalign_gb1_coupling"].any()
    assert np.array_equal(hss["te_gb1_mesh2"], psd["te_gb1_mesh2"])
    assert (order_of(stages, "mesh2") / order_of(stages, "hss")).denominator != 1
    mesh2 = excitation_psds(exc, stages, names, f, rot, load, res, [order_of(stages, "mesh2")])
    assert not mesh2["te_gb1_mesh2"].any()
    assert np.array_equal(mesh2["misalign_gb1_coupling"], psd["misalign_gb1_coupling"])


def test_each_data_version_is_predicted_from_the_noise_it_holds(bench):
    # The quiet bench of the fixture with the default gear excitation switched on:
    # - raw data hold the gear lines: the band of the torque-meter pairing ends inside a
    #   line's sweep (computed here from the orders and the set-point's speed range),
    #   below the band without excitation;
    # - clean data (no gear excitation; the sensor noise kept as the reference), and a
    #   removal of every family's cycle (hss, mesh1, mesh2), both give exactly the
    #   prediction without gear excitation.
    c0, closed, truths = bench
    c = copy.deepcopy(c0)
    c["excitation"]["gearboxes"] = ["gb1", "gb2"]
    c["identify"] = {**c["identify"], "versions": ["clean", "raw", "tsa"]}
    c["tsa"] = {**c["tsa"], "tests": ["hss", "mesh1", "mesh2"]}
    assert c["excitation"]["shaft_orders"] and c["excitation"]["mesh"]
    quiet = _torque_test(c0, closed, truths).sel(pairing="Tdrn_to_Mdrn")
    pair = "Tdrn_to_Mdrn"
    clean, raw, tsa = (_torque_test(c, closed, truths, version=v).sel(pairing=pair)
                       for v in ("clean", "raw", "tsa"))
    f = clean.frequency.values
    assert float(raw.predicted_hz) < float(quiet.predicted_hz)
    _, w, _ = step_reference(c["campaign"], "torque_up", "tapered")
    lo, hi = float(w.min()) / (2 * np.pi), float(w.max()) / (2 * np.pi)
    stages, exc = c["gearbox"]["stages"], c["excitation"]
    orders = [float(s["order"]) for s in exc["shaft_orders"]]
    orders += [h * float(order_of(stages, f"mesh{m['stage']}")) for m in exc["mesh"]
               for h in range(1, len(m["harmonics"]) + 1)]
    first_miss = f[np.argmax(f > float(raw.predicted_hz))]
    assert any(o * lo - 0.5 <= first_miss <= o * hi + 0.5 for o in orders), first_miss
    for name in ("predicted_hz", "predicted_error_db", "snr_db"):
        for version in (clean, tsa):
            np.testing.assert_allclose(version[name].values, quiet[name].values, rtol=1e-9)
