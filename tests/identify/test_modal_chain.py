"""The modes of a bench nobody modelled: an openTorsion chain, written as bench files, read
and analysed by the modes stage with nothing but a ``measured:`` mapping.

The truth is independent of gbpipe: the chain's matrices from openTorsion, its record from
scipy, its modes from :func:`scipy.linalg.eig` (tests/identify/opentorsion_chain.py). A
mode can be asked of the data only where the data show it: a resonance peak (>= 3 dB
prominence) of the chain's true FRF from the motor torque to an output, where the
coherence of the record (scipy's Welch estimate, independent of gbpipe's) reaches
``identify.nonparametric.coherence_min``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from gbpipe.config import load, measured_specs, merge, validate
from gbpipe.identify import identify_record, modes_table_rows, record_modes
from gbpipe.identify.modal import TABLE_COLUMNS
from gbpipe.identify.orders import stabilization_orders
from gbpipe.measured import read
from tests.conftest import CONFIG
from tests.identify import opentorsion_chain as oc

FS, DURATION, SEGMENT = 2000.0, 60.0, 2.0


def visible_modes(truth: oc.ChainTruth, data: dict, f_band: tuple[float, float],
                  coherence_min: float) -> np.ndarray:
    """True modes in ``f_band`` [Hz] with a resonance peak the record's data resolve."""
    a, b, c, d = oc.plant(oc.chain())
    f = np.arange(f_band[0], f_band[1], 0.05)
    out = []
    for row, channel in ((0, "torque meter"), (1, "load speed")):
        h = np.array([c[row] @ np.linalg.solve(2j * np.pi * fk * np.eye(len(a)) - a, b[:, 0])
                      for fk in f]) + d[row, 0]
        peaks, _ = signal.find_peaks(20 * np.log10(np.abs(h)), prominence=3.0)
        fc, coh = signal.coherence(data["motor torque"], data[channel], fs=FS,
                                   nperseg=int(SEGMENT * FS))
        for fp in f[peaks]:
            if np.interp(fp, fc, coh) >= coherence_min:
                out.append(truth.frequency_hz[np.argmin(np.abs(truth.frequency_hz - fp))])
    return np.unique(out)


#: Two benches: the lines sweep other bands, the noise is another draw.
CASES = {"10Hz_mesh23": {"seed": 3, "shaft_hz": (10.0, 10.4), "mesh_order": 23.0},
         "14Hz_mesh17": {"seed": 11, "shaft_hz": (14.0, 14.8), "mesh_order": 17.0}}


@pytest.fixture(scope="module", params=list(CASES))
def chain_modes(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp("chain")
    truth = oc.write_bench(folder, fs=FS, duration=DURATION, **CASES[request.param])
    # a measured: mapping and the pairing only; nothing of the chain
    cfg = merge(load(CONFIG), {
        "measured": {"chain": truth.spec},
        "identify": {"versions": ["raw"], "nonparametric": {"segment": SEGMENT},
                     "pairings": [{"name": "Tm_to_M_w", "inputs": ["motor_torque"],
                                   "outputs": ["torque_meter", "load_speed"]}]}})
    spec = measured_specs(cfg)["chain"]
    record = read(truth.spec, base_dir=folder, name="chain")
    ds = record_modes(cfg, record, spec.orders)
    return truth, cfg, ds, truth.signals, record


def test_every_visible_mode_found_and_no_line_called_a_mode(chain_modes):
    truth, cfg, ds, data, _ = chain_modes
    s = cfg["identify"]
    band = (s["frf"]["f_min"], s["frf"]["f_max"])
    need = visible_modes(truth, data, band, s["nonparametric"]["coherence_min"])
    assert need.size >= 3  # the chain shows at least three modes: the test is not empty
    for method in ds.method.values:
        d = ds.sel({"method": method}).isel(pairing=0)
        assert str(d.status.values) == "ok"
        kind = d.mode_kind.values
        f, z = d.mode_frequency.values, d.mode_damping.values
        modes = np.isfinite(f) & (kind == "mode")
        for fm in need:  # LSCF too: it fits every line but DC, no band edge in the band
            zm = truth.damping[np.argmin(np.abs(truth.frequency_hz - fm))]
            k = np.flatnonzero(modes & (np.abs(f - fm) <= 0.01 * fm))
            assert k.size == 1, f"{method}: mode {fm:.2f} Hz found {k.size} times in {f}"
            assert abs(z[k[0]] - zm) <= 0.2 * zm, f"{method}: {fm:.2f} Hz damping {z[k[0]]}"
        # every reported mode is a mode of the chain (no order line, no noise pole)
        for fk in f[modes]:
            assert np.min(np.abs(truth.frequency_hz - fk)) <= 0.01 * fk, f"{method}: {fk}"


def test_order_lines_are_labelled_harmonic(chain_modes):
    truth, cfg, ds, _, _ = chain_modes
    res = 1.0 / SEGMENT
    # the lines' frequency ranges from the chain's own speed sweep and orders
    lines = [(k * truth.shaft_hz[0] - res, k * truth.shaft_hz[1] + res) for k in truth.orders]
    n_lines = 0
    for method in ds.method.values:
        d = ds.sel({"method": method}).isel(pairing=0)
        for fk, kind in zip(d.mode_frequency.values, d.mode_kind.values, strict=True):
            on_line = any(lo <= fk <= hi for lo, hi in lines)
            n_lines += on_line
            if on_line:
                assert kind == "harmonic", f"{method}: the line at {fk:.2f} Hz is a {kind}"
    assert n_lines >= 1  # a line does make a stable cluster: the labels were tested


def test_model_order_is_the_lowest_holding_every_mode_and_its_lines(chain_modes):
    """The order holds every mode either method found and the order lines of its own
    band, and no lower order does: noise poles do not choose it. The orders are those of
    the diagram at the identification rate (the model's), not its zoomed bands; a mode
    none of them holds is named in the status."""
    _, cfg, ds, _, _ = chain_modes
    tol = cfg["identify"]["stabilization"]["frequency_tolerance"]
    kind = ds.mode_kind.values[:, 0]
    modes = ds.mode_frequency.values[:, 0][kind == "mode"]
    assert modes.size >= 3
    for i, method in enumerate(ds.method.values):
        d = ds.sel({"method": method}).isel(pairing=0)
        # its own lines: those its diagram at the identification rate found (a zoomed
        # band's line clusters sit elsewhere on a sweeping line than its poles)
        need = np.concatenate([modes, d.mode_frequency.values[
            (kind[i] == "harmonic") & (d.mode_decimation.values == 1)]])

        def holds(poles, need=need):
            return all(np.nanmin(np.abs(poles - fk), initial=np.inf) <= tol * fk
                       for fk in need)

        poles = d.model_pole_frequency.values
        some = [any(holds(p, [fk]) for p in poles) for fk in need]
        for fk in need[~np.asarray(some)]:
            assert f"{fk:.1f}" in str(d.status.values), (fk, str(d.status.values))
        need = need[np.asarray(some)]
        rows = np.flatnonzero(d.order.values == int(d.model_order))
        assert rows.size == 1
        assert holds(poles[rows[0]], need)
        assert not any(holds(poles[k], need) for k in range(rows[0]))
    # the table: one row per cluster, the documented columns in order
    rows = modes_table_rows(ds, "chain")
    assert rows and all(tuple(r) == TABLE_COLUMNS for r in rows)
    assert len(rows) == int(np.isfinite(ds.mode_frequency.values).sum())



def test_models_at_the_stabilization_order_are_ok_only_where_they_match_the_chain(chain_modes):
    """Identified at the order its own stabilization diagram chose (nothing of the
    configured gearbox), every model called ``ok`` has a hold-out fit of at least
    ``identify.fit_min`` and matches the chain's true FRF (openTorsion's matrices, not the
    data) within the tolerance over its match band; at least one model is ``ok``."""
    truth, cfg, ds, _, record = chain_modes
    # the derived keys (identify.order: stabilization, max_order) of a complete config
    cfg = validate(merge(cfg, {"spectra": {"signal": "torque_meter"}}))
    s = cfg["identify"]
    orders, source = stabilization_orders(ds, "pbsid", [p["name"] for p in s["pairings"]],
                                          "chain.nc")
    out = identify_record(cfg, record, None, None, "pbsid", {}, orders=orders,
                          order_source=source, line_orders=truth.orders)
    status = out.status.values
    assert (status == "ok").any(), list(zip(status, out.reason.values, strict=True))
    a, b, c, d = oc.plant(oc.chain())
    f = out.frequency.values
    g_true = np.array([c @ np.linalg.solve(2j * np.pi * fk * np.eye(len(a)) - a, b[:, :1])
                       + d[:, :1] for fk in f])
    for m in np.flatnonzero(status == "ok"):
        assert np.nanmin(out.fit.values[m]) >= s["fit_min"]
        band = f <= float(out.match_bandwidth.values[m])
        g_id = (out.frf_identified_real.values[m] + 1j * out.frf_identified_imag.values[m])
        err_db = np.abs(20 * np.log10(np.abs(g_id[band]) / np.abs(g_true[band])))
        # the band is judged against the nonparametric estimate where it is coherent:
        # against the truth, the median point must lie within the tolerance
        assert np.median(err_db) <= s["tolerance_db"], (m, np.median(err_db))
