"""Zoomed diagrams: a mode low in the band that the identification rate's LSCF diagram
misses is found by the diagram of the data decimated (``identify.stabilization.zoom``),
at its closed-form frequency and damping; what the identification rate's diagram found
stands unchanged, and the identify stage's model order is still read off that diagram.

The record: three single-degree-of-freedom oscillators driven by one random torque (the
speed their sum), simulated exactly by scipy (zero-order hold), with white output noise.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy import signal

from gbpipe import io
from gbpipe.config import load, merge
from gbpipe.figures import stabilization_plots
from gbpipe.figures.stabilization_plots import stabilization_figure
from gbpipe.identify import record_modes
from gbpipe.identify.modal_diagrams import join_bands, zoom_bands
from gbpipe.sysid import Stabilization, join_poles, select_poles, stabilize
from tests.conftest import CONFIG

FS, SEGMENT, ZETA = 1000.0, 4.0, 0.02  # Hz, s, -
LOW = 8.0  # Hz: the mode low in the band
MODES = ((LOW, 0.3), (150.0, 1.0), (260.0, 1.0))  # (Hz, gain 1/(kg m^2))


def _record(seed: int) -> xr.Dataset:
    rng = np.random.default_rng(seed)
    t = np.arange(int(40 * FS)) / FS
    u = 50.0 * rng.standard_normal(t.size)
    y = np.zeros(t.size)
    for f0, gain in MODES:
        wn = 2 * np.pi * f0
        a = np.array([[0.0, 1.0], [-wn ** 2, -2 * ZETA * wn]])
        b, c = np.array([[0.0], [gain]]), np.array([[0.0, 1.0]])
        sysd = signal.cont2discrete((a, b, c, np.zeros((1, 1))), 1 / FS, method="zoh")
        y += signal.dlsim(sysd[:4] + (1 / FS,), u, t)[1][:, 0]
    y += 0.5 * y.std() * rng.standard_normal(t.size)
    return xr.Dataset({"torque": ("time", u, {"units": "N m", "long_name": "torque"}),
                       "speed": ("time", y, {"units": "rad/s", "long_name": "speed"})},
                      coords={"time": ("time", t, {"units": "s", "long_name": "time"})},
                      attrs={"sample_rate": FS, "record": "three", "record_kind": "measured"})


def _cfg(zoom: int | None = None) -> dict:
    # zoom None: the default
    return merge(load(CONFIG), {"campaign": {"settle": 1.0}, "identify": {
        "versions": ["raw"], "nonparametric": {"segment": SEGMENT},
        "pairings": [{"name": "T_w", "inputs": ["torque"], "outputs": ["speed"]}],
        "stabilization": {} if zoom is None else {"zoom": zoom}}})


def _rows(ds: xr.Dataset, method: str) -> xr.Dataset:
    d = ds.sel({"method": method}).isel(pairing=0)
    return d.isel(cluster=np.flatnonzero(np.isfinite(d.mode_frequency.values)))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_low_mode_the_full_rate_lscf_misses_is_found_zoomed(seed):
    rec = _record(seed)
    plain, zoomed = record_modes(_cfg(1), rec), record_modes(_cfg(), rec)
    assert _cfg()["identify"]["stabilization"]["zoom"] > 1
    near = lambda d: np.abs(d.mode_frequency.values - LOW) <= 0.01 * LOW  # noqa: E731
    # without the zoom the LSCF diagram holds no cluster at the low mode: the test bites
    assert not near(_rows(plain, "lscf")).any()
    d = _rows(zoomed, "lscf")
    k = np.flatnonzero(near(d))
    assert k.size == 1 and d.mode_kind.values[k[0]] == "mode", d.mode_evidence.values
    assert d.mode_decimation.values[k[0]] > 1
    # damping: the truth, widened at most by the Hann window's 3 dB bandwidth (1.44
    # lines of 1 / SEGMENT) that the Welch estimate the LSCF fits adds to the resonance
    assert 0.8 * ZETA <= d.mode_damping.values[k[0]] <= ZETA + 1.44 / SEGMENT / (2 * LOW)
    # what the identification rate's diagrams found stands as it was
    for method in plain.method.values:
        a, b = _rows(plain, method), _rows(zoomed, method)
        for f, z in zip(a.mode_frequency.values, a.mode_damping.values, strict=True):
            j = np.argmin(np.abs(b.mode_frequency.values - f))
            assert abs(b.mode_frequency.values[j] - f) <= 1e-9 * f
            assert abs(b.mode_damping.values[j] - z) <= 1e-9 * z
    # the model order is the identification rate's: the lowest order of its diagram (the
    # one without the zoom) with a pole within the frequency tolerance of every mode
    # either method found that some order of it holds, and a mode no order of it holds
    # is named in the status
    # (and the lines it fitted at its rate, the harmonic rows of decimation 1)
    tol = _cfg()["identify"]["stabilization"]["frequency_tolerance"]
    modes = np.concatenate([d.mode_frequency.values[d.mode_kind.values == "mode"]
                            for d in (_rows(zoomed, m) for m in zoomed.method.values)])
    for method in plain.method.values:
        p, z = (x.sel({"method": method}).isel(pairing=0) for x in (plain, zoomed))
        w = p.pole_frequency.shape[-1]  # poles per order, NaN-padded to the widest order
        np.testing.assert_array_equal(z.model_pole_frequency.values[:, :w], p.pole_frequency)
        assert np.isnan(z.model_pole_frequency.values[:, w:]).all()
        r = _rows(zoomed, method)
        wanted = np.concatenate([modes, r.mode_frequency.values[
            (r.mode_kind.values == "harmonic") & (r.mode_decimation.values == 1)]])
        held = np.array([[np.any(np.abs(row - f) <= tol * f) for f in wanted]
                         for row in p.pole_frequency.values])
        every = held[:, held.any(axis=0)].all(axis=1)
        if not modes.size:
            lowest = 0
        elif every.any():
            lowest = p.order.values[np.flatnonzero(every)[0]]
        else:
            lowest = p.order.values[-1]
        assert int(z.model_order) == int(lowest)
        if held[:, :modes.size].any(axis=0).all():
            assert str(z.status.values) == "ok"
        else:
            assert str(z.status.values).startswith("poor")
            assert f"{LOW:.1f}" in str(z.status.values)


def test_the_bands_are_the_pass_bands_of_each_decimation():
    # identify.sample_rate 1000 Hz, lowpass 0.8, f_min 5 Hz: 65 % of the 250 and 62.5 Hz
    # rates' pass bands (100 and 25 Hz); 15.6 Hz would reach 4.1 Hz only, under an octave
    # above f_min
    s = _cfg(4)["identify"]
    assert s["sample_rate"] == FS and s["lowpass"] == 0.8 and s["frf"]["f_min"] == 5.0
    np.testing.assert_allclose(zoom_bands(s, FS), [(1, 65.0, np.inf), (4, 16.25, 65.0),
                                                   (16, 0.0, 16.25)], rtol=1e-12)
    assert zoom_bands(_cfg(1)["identify"], FS) == [(1, 0.0, np.inf)]


def test_joined_poles_are_each_diagrams_kept_poles_in_order():
    rng = np.random.default_rng(1)
    parts = []
    for _ in range(2):
        poles = []
        for n in (3, 5):
            f = np.sort(rng.uniform(1, 100, n))
            poles.append((f, rng.uniform(0, 0.1, n), rng.standard_normal((n, 2)) + 0j))
        parts.append(poles)
    kept = [select_poles(parts[0], lambda f: f >= 50), select_poles(parts[1], lambda f: f < 50)]
    joined = join_poles(kept)
    for k in range(2):
        f = np.concatenate([parts[0][k][0][parts[0][k][0] >= 50],
                            parts[1][k][0][parts[1][k][0] < 50]])
        assert np.array_equal(joined[k][0], np.sort(f))
        # each pole keeps its own damping and shape
        for fk, zk, vk in zip(*joined[k], strict=True):
            src = parts[0][k] if fk >= 50 else parts[1][k]
            i = int(np.flatnonzero(src[0] == fk)[0])
            assert zk == src[1][i] and np.array_equal(vk, src[2][i])


def test_the_figure_dots_the_bands_edges_on_a_frequency_axis(tmp_path, monkeypatch):
    """Through the file the workflow writes and reads: the zoomed bands' edges are dotted
    at their frequencies on a numeric frequency axis, and the caption lists each cluster."""
    ds = record_modes(_cfg(), _record(0))
    io.write(ds, tmp_path / "three.nc", stage="modes_measured")
    back = io.read(tmp_path / "three.nc")
    edges = back.zoom_edge_frequency.values
    assert edges.dtype.kind == "f" and edges.size >= 1
    np.testing.assert_allclose(edges, [b[2] for b in zoom_bands(_cfg()["identify"], FS)[1:]])
    drawn = []
    monkeypatch.setattr(stabilization_plots, "save", lambda fig, path: drawn.append(fig))
    numbers = stabilization_figure(back, "T_w", "three", {"png": tmp_path / "f.png",
                                                          "caption": tmp_path / "f.md"})
    for ax in drawn[0].axes[:back.method.size]:  # each method's axes (then the twins)
        assert ax.get_xlim() == (back.frequency.values[0], back.frequency.values[-1])
        dotted = sorted(line.get_xdata()[0] for line in ax.lines
                        if line.get_linestyle() == ":")
        np.testing.assert_allclose(dotted, np.sort(edges))
    for method in back.method.values:
        d = _rows(back, method)
        for f in d.mode_frequency.values:
            assert f"{f:.1f} Hz" in numbers[f"{method} clusters"]


def _diagram(modes: dict[float, float], orders: np.ndarray) -> Stabilization:
    """A diagram whose pole at each order is ``f (1 + jitter(k))`` for every mode ``f``:
    ``jitter`` 0 gives a pole that drifts by 1e-4 per order (stable), a non-zero one
    alternates its sign (a pole that jumps between orders)."""
    poles = []
    for k in range(orders.size):
        f = np.sort([f0 * (1 + (1e-4 * k if j == 0 else j * (-1) ** k))
                     for f0, j in modes.items()])
        poles.append((f, np.full(f.size, 0.02), np.ones((f.size, 1), complex)))
    return stabilize(orders, poles, "pbsid")


def test_a_zoomed_diagram_keeps_its_cluster_below_its_band():
    """A mode below a zoomed band's edge that its diagram holds and the band below does
    not (its poles there jump 3 % between orders) is read from the zoomed diagram: the
    joined cluster is that diagram's, pole for pole, and says so in its decimation. A mode
    that both hold is read from the less decimated diagram, as the identification rate's
    own clusters are."""
    orders = np.arange(2, 42, 2)
    crit = {"frequency_tolerance": 0.01, "damping_tolerance": 0.05, "mac_min": 0.95}
    res = [(_diagram({60.0: 0.0}, orders), 1, 40.0, np.inf),
           (_diagram({10.0: 0.0, 12.1: 0.0, 30.0: 0.0}, orders), 2, 20.0, 40.0),
           (_diagram({10.0: 0.015, 12.0: 0.0, 15.0: 0.0}, orders), 4, 0.0, 20.0)]
    assert not any(abs(m.frequency_hz - 10.0) < 0.5 for m in res[2][0].clusters)
    d = join_bands(res, "pbsid", crit)
    low = [m for m in d.joined.clusters if abs(m.frequency_hz - 10.0) < 0.5]
    # stable at every order but the first (which has no order before it to match)
    assert len(low) == 1 and low[0].n_orders == orders.size - 1
    # the zoomed diagram's poles: the median of 10 (1 + 1e-4 k) over k = 1 .. 19
    assert low[0].frequency_hz == pytest.approx(10.0 * (1 + 1e-4 * orders.size / 2),
                                                rel=1e-12)
    assert d.decimation(low[0].frequency_hz, crit["frequency_tolerance"]) == 2
    # the joined diagram's poles near each of the two modes below the zoomed band are the
    # zoomed diagram's (12 Hz: though the band below holds it too)
    for f0 in (10.0, 12.1):
        for (f, *_), (fz, *_) in zip(d.joined.poles, res[1][0].poles, strict=True):
            assert np.array_equal(f[np.abs(f - f0) < 0.5], fz[np.abs(fz - f0) < 0.5])
    assert sorted(round(m.frequency_hz) for m in d.joined.clusters) == [10, 12, 15, 30, 60]
    assert [d.decimation(f, 0.01) for f in (12.1, 15.0, 30.0, 60.0)] == [2, 4, 2, 1]


def test_a_zoomed_diagram_keeps_nothing_above_its_band():
    """Above a zoomed band's top the diagram above keeps its poles alone: a cluster of the
    zoomed diagram above its band (near its anti-aliasing edge) keeps none, and one that
    straddles the top keeps those below it, so that no frequency holds two diagrams'
    poles (whose scatter would match each other's, order to order)."""
    orders = np.arange(2, 42, 2)
    crit = {"frequency_tolerance": 0.01, "damping_tolerance": 0.05, "mac_min": 0.95}
    zoomed = _diagram({30.0: 0.0, 45.0: 0.0}, orders)
    # a cluster straddling the top (40 Hz): its poles alternate 39.85 and 40.05 Hz (0.5 %
    # apart: stable), its median (of the stable ones, orders 1-19) 39.85 Hz below the top
    for k, (f, *_) in enumerate(zoomed.poles):
        f = np.sort(np.append(f, 39.85 if k % 2 else 40.05))
        zoomed.poles[k] = (f, np.full(f.size, 0.02), np.ones((f.size, 1), complex))
    zoomed = stabilize(orders, zoomed.poles, "pbsid")
    assert any(abs(m.frequency_hz - 39.85) < 1e-9 for m in zoomed.clusters)
    assert any(abs(m.frequency_hz - 45.0) < 0.1 for m in zoomed.clusters)
    top = _diagram({40.3: 0.006, 60.0: 0.0}, orders)  # poles jumping 1.2 % above the top
    d = join_bands([(top, 1, 40.0, np.inf), (zoomed, 2, 0.0, 40.0)], "pbsid", crit)
    for (f, *_), (ft, *_), (fz, *_) in zip(d.joined.poles, top.poles, zoomed.poles,
                                           strict=True):
        mine = np.sort(np.concatenate([fz[(fz > 35) & (fz < 40)], ft[(ft >= 40) & (ft < 50)]]))
        assert np.array_equal(f[(f > 35) & (f < 50)], mine)
    assert not any(abs(m.frequency_hz - 45.0) < 1.0 for m in d.joined.clusters)
