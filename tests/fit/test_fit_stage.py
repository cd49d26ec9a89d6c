"""The fit stage's library part (gbpipe.fit.stage): identified FRFs in, masked and
weighted; the stage dataset out, with units on every variable."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.fit import fit_data, fit_dataset, fit_parameters
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.model import Pairing, pairing_frf

FREE = ["gearbox.stiffness[1]", "gearbox.inertia[0]", "bench.coupling.stiffness"]


def _pairings(cfg) -> list[Pairing]:
    return [Pairing.from_config(p) for p in cfg["identify"]["pairings"]
            if p["name"] in ("Tdrn_to_wdrn", "Tdrn_to_Mdrn", "Tdrv_to_wdrv")]


def _identified(cfg, truth, pairings, f, db_width):
    """An identify-stage-like dataset holding the true FRFs and a +-db_width band."""
    g = pairing_frf(truth, pairings, f)
    n = len(pairings)
    frf = np.full((n, f.size, 2, 2), np.nan, complex)
    for k, gk in enumerate(g):
        frf[k, :, :gk.shape[1], :gk.shape[2]] = gk
    mag = 20 * np.log10(np.abs(frf))
    width = np.broadcast_to(np.asarray(db_width, float)[:, None, None, None], frf.shape)
    dims = ("model", "frequency", "output", "input")
    return xr.Dataset({
        "pairing": ("model", [p.name for p in pairings]),
        "version": ("model", ["clean"] * n),
        "status": ("model", ["ok"] * n),
        "frf_unit": ("model", ["1"] * n),
        "frf_identified_real": (dims, frf.real), "frf_identified_imag": (dims, frf.imag),
        "frf_identified_lower_db": (dims, mag - width),
        "frf_identified_upper_db": (dims, mag + width),
    }, coords={"frequency": f})


def _identifiable(pairings, f, top):
    return xr.DataArray(np.array([f <= t for t in top]), dims=("pairing", "frequency"),
                        coords={"pairing": [p.name for p in pairings], "frequency": f})


def test_masks_follow_band_and_prediction_and_weights_follow_bounds(cfg):
    f = np.geomspace(5.0, 350.0, 80)
    pairings = _pairings(cfg)
    ident = _identified(cfg, cfg, pairings, f, [0.1, 0.2, 1.0])
    mask = _identifiable(pairings, f, [350.0, 100.0, 0.0])
    data = fit_data(ident, mask, pairings, "clean", (10.0, 300.0), "pairing")
    # the third pairing is nowhere predicted identifiable: left out
    assert [d.pairing.name for d in data] == [p.name for p in pairings[:2]]
    used = [d.mask[:, 0, 0] for d in data]
    assert np.array_equal(used[0], (f >= 10) & (f <= 300))
    assert np.array_equal(used[1], (f >= 10) & (f <= 100))
    # +-0.1 dB at 95 %: sigma = ln(10^(0.2/20)) / (2 * 1.96) Np, one value per pairing
    expect = np.log(10 ** (0.2 / 20)) / (2 * 1.959964)
    assert np.allclose(data[0].sigma[used[0]], expect, rtol=1e-6)
    assert np.allclose(data[1].sigma[used[1]], 2 * expect, rtol=1e-6)
    assert fit_data(ident, mask, pairings, "clean", (10.0, 300.0), "uniform")[0].sigma is None
    with pytest.raises(DataError, match=f"no model of pairing {pairings[0].name}, version raw"):
        fit_data(ident, mask, pairings, "raw", (10.0, 300.0), "pairing")
    with pytest.raises(DataError, match="no pairing is predicted identifiable"):
        fit_data(ident, _identifiable(pairings, f, [0.0] * 3), pairings, "clean",
                 (10.0, 300.0), "pairing")
    with pytest.raises(DataError, match="frequency grid differs"):
        fit_data(ident, _identifiable(pairings, f * 1.01, [350.0] * 3), pairings, "clean",
                 (10.0, 300.0), "pairing")


def test_stage_dataset_recovers_a_perturbed_bench_and_names_units(cfg):
    f = np.geomspace(5.0, 350.0, 120)
    pairings = _pairings(cfg)
    truth = with_values(cfg, {FREE[0]: 1.95e7, FREE[1]: 8749.0, FREE[2]: 4.953e6})
    ident = _identified(cfg, truth, pairings, f, [0.05, 0.05, 0.05])
    data = fit_data(ident, _identifiable(pairings, f, [350.0] * 3), pairings, "clean",
                    (5.0, 350.0), "pairing")
    res = fit_parameters(cfg, data, FREE, n_starts=2)
    ds = fit_dataset(res, data, cfg, ident, "clean")
    true = np.array([get_value(truth, p) for p in FREE])
    assert np.allclose(ds.estimate.values, true, rtol=1e-4)
    assert np.allclose(ds.prior.values, [get_value(cfg, p) for p in FREE])
    assert list(ds.parameter_units.values) == ["N m rad-1", "kg m2", "N m rad-1"]
    assert np.all(ds.status.values == "identified")
    assert np.all((ds.interval_lower.values <= true) & (true <= ds.interval_upper.values))
    # the fitted model equals the truth on the whole grid; the prior does not
    for name, far in (("frf_fitted", False), ("frf_prior", True)):
        g = ds[f"{name}_real"].values + 1j * ds[f"{name}_imag"].values
        d = ds.frf_data_real.values + 1j * ds.frf_data_imag.values
        err = np.nanmax(np.abs(np.log(g / d)))
        assert (err > 0.1) if far else (err < 1e-4)
    for v in list(ds.data_vars) + list(ds.coords):
        assert "units" in ds[v].attrs and "long_name" in ds[v].attrs, v
    # design help: the present outputs already determine all three parameters
    assert int(ds.design_rank.values[0]) == 3
