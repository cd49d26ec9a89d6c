"""The modes stage on a one-mode record: the closed-form mode, no tacho, and a failed diagram
that says why without hiding the other one."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy import signal

import gbpipe.identify.modal_diagrams as modal_diagrams
from gbpipe.config import load, merge
from gbpipe.errors import DataError, ExcitationError
from gbpipe.identify import record_modes
from tests.conftest import CONFIG

FS, F0, ZETA, J = 1000.0, 40.0, 0.02, 0.5  # Hz, Hz, -, kg m^2


def _one_mode_record(seed: int, noise: float) -> tuple[dict, xr.Dataset]:
    # a torsional oscillator J x'' + c x' + k x = T: one mode at F0 with damping ZETA;
    # output noise of `noise` times the speed's RMS (white: it buries the 1/f response
    # at the top of the band first, as on a bench)
    wn = 2 * np.pi * F0
    a = np.array([[0.0, 1.0], [-wn ** 2, -2 * ZETA * wn]])
    b, c = np.array([[0.0], [1.0 / J]]), np.array([[0.0, 1.0]])
    rng = np.random.default_rng(seed)
    t = np.arange(int(40 * FS)) / FS
    u = 50.0 * rng.standard_normal(t.size)
    sysd = signal.cont2discrete((a, b, c, np.zeros((1, 1))), 1 / FS, method="zoh")
    _, y, _ = signal.dlsim(sysd[:4] + (1 / FS,), u, t)
    y = y[:, 0] + noise * y.std() * rng.standard_normal(t.size)
    rec = xr.Dataset({"torque": ("time", u, {"units": "N m", "long_name": "torque"}),
                      "speed": ("time", y, {"units": "rad/s", "long_name": "speed"})},
                     coords={"time": ("time", t, {"units": "s", "long_name": "time"})},
                     attrs={"sample_rate": FS, "record": "one_mode", "record_kind": "measured"})
    cfg = merge(load(CONFIG), {"campaign": {"settle": 1.0}, "identify": {
        "versions": ["raw"], "pairings": [{"name": "T_w", "inputs": ["torque"],
                                           "outputs": ["speed"]}]}})
    return cfg, rec


@pytest.fixture(scope="module")
def one_mode():
    return _one_mode_record(5, 0.02)


def test_closed_form_mode_without_tacho(one_mode):
    cfg, rec = one_mode
    ds = record_modes(cfg, rec)
    assert ds.harmonic_order.size == 0  # no tacho, no lines: every cluster is a mode
    for method in ds.method.values:
        d = ds.sel({"method": method}).isel(pairing=0)
        assert str(d.status.values) == "ok"
        f, z = d.mode_frequency.values, d.mode_damping.values
        k = np.flatnonzero(np.abs(f - F0) <= 0.01 * F0)
        assert k.size == 1 and abs(z[k[0]] - ZETA) <= 0.2 * ZETA, (method, f, z)
        assert set(d.mode_kind.values[np.isfinite(f)]) == {"mode"}
        assert int(d.model_order) >= 2


@pytest.mark.parametrize(("seed", "noise"), [(6, 0.3), (7, 1.0)])
def test_no_mode_at_the_band_edge_where_the_record_is_incoherent(seed, noise):
    # the top of the FRF band (identify.frf.f_max) lies where the noise buries the
    # response (coherence 0.1 and 0.006 at 340 Hz); a fit that ends there put a lightly
    # damped pole at its edge (348 Hz on the second record) and called it a mode
    cfg, rec = _one_mode_record(seed, noise)
    ds = record_modes(cfg, rec)
    for method in ds.method.values:
        d = ds.sel({"method": method}).isel(pairing=0)
        f, z = d.mode_frequency.values, d.mode_damping.values
        f, z = f[np.isfinite(f)], z[np.isfinite(f)]
        assert f.size == 1 and abs(f[0] - F0) <= 0.01 * F0, (method, f)
        assert abs(z[0] - ZETA) <= 0.2 * ZETA, (method, z)


def test_failed_diagram_says_why_and_the_other_stands(one_mode, monkeypatch):
    cfg, rec = one_mode

    def refuse(*args, **kwargs):
        raise ExcitationError("input torque is not persistently exciting of order 60")

    monkeypatch.setattr(modal_diagrams, "stabilization_diagram", refuse)
    ds = record_modes(cfg, rec)
    sub = ds.sel({"method": cfg["identify"]["stabilization"]["method"]}).isel(pairing=0)
    assert str(sub.status.values).startswith("failed: ExcitationError: input torque")
    assert int(sub.model_order) == 0 and not np.isfinite(sub.mode_frequency.values).any()
    lscf = ds.sel({"method": "lscf"}).isel(pairing=0)
    assert str(lscf.status.values) == "ok"
    assert np.any(np.abs(lscf.mode_frequency.values - F0) <= 0.01 * F0)


def test_a_speed_that_is_not_a_speed_refused_before_any_diagram(one_mode, monkeypatch):
    cfg, rec = one_mode
    monkeypatch.setattr(modal_diagrams, "stabilization_diagram", pytest.fail)  # never reached
    with pytest.raises(DataError, match="must be a speed"):
        record_modes(cfg, rec, orders=[23.0], speeds={"torque": 1.0})
