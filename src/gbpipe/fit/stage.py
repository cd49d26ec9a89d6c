"""The fit stage: identified models in, fitted physical parameters out (rule ``fit``).

:func:`fit_data` turns one identify output (``identify/{record}_{method}.nc``) into the
FRFs to fit: one version's identified FRFs of the chosen pairings, inside the fitted band
and where the design step (``design/{record}.nc``, computed from the bench model and the
excitation before identification) predicts each pairing identifiable, weighted by the
models' 95 % bounds. :func:`fit_dataset` writes what came out: estimates, intervals,
correlations, what the data cannot separate, the FRFs before and after, and which added
output would determine what is undetermined. See docs/fit.md.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.fit.bands import jackknife_intervals
from gbpipe.fit.estimate import FitResult, fit_parameters
from gbpipe.fit.frf_data import KERNEL_REACH, FrfData, sigma_from_bounds
from gbpipe.fit.identifiability import design_outputs
from gbpipe.fit.modes import read_modes_table
from gbpipe.fit.report import cf_var, modal_fit_dataset, result_variables
from gbpipe.lti import pad
from gbpipe.model.assembly import bench_chain, bench_ss
from gbpipe.model.chain import Motor
from gbpipe.model.frf import MOTOR_INPUTS, Pairing, pairing_frf

__all__ = ["fit_data", "nonparametric_data", "fit_dataset", "fit_record", "assessable_band",
           "WEIGHTS", "CANDIDATE_OUTPUTS"]

log = logging.getLogger(__name__)

#: Residual weightings: one sigma per pairing (the median of its 95 % bounds), per
#: frequency (the bounds themselves), or none. A 3-group jackknife gives each frequency's
#: sigma with 2 degrees of freedom: weighting single frequencies by it follows its scatter
#: (docs/fit.md), so the default uses the bounds only to weigh pairings against each other.
WEIGHTS = ("pairing", "bounds", "uniform")
#: Outputs a design-help candidate may add (each with every fitted input).
CANDIDATE_OUTPUTS = ("speed_gb2_hss", "speed_gb1_hss", "speed_lss", "torque_meter_driving",
                     "torque_meter_driven")
def _model_index(identified: xr.Dataset, pairing: str, version: str) -> int:
    hit = np.nonzero((identified.pairing.values == pairing)
                     & (identified.version.values == version))[0]
    if hit.size != 1:
        raise DataError(f"identified models ({identified.attrs.get('test', '?')})",
                        f"no model of pairing {pairing}, version {version}: identify it "
                        "(identify.pairings, identify.versions)")
    return int(hit[0])


def assessable_band(identified: xr.Dataset, version: str) -> xr.DataArray:
    """Where a bench record's models can be judged: per pairing, the frequencies at which
    the nonparametric FRF of the data is coherent (``assessable`` of the identify stage).

    A bench record has no design step (its excitation is not the config's), so this mask
    stands in for the predicted identifiable band of :func:`fit_data`.
    """
    rows = np.nonzero(identified.version.values == version)[0]
    if rows.size == 0:
        raise DataError(f"identified models ({identified.attrs.get('test', '?')})",
                        f"no model of version {version}: identify it (identify.versions)")
    sub = identified.isel(model=rows)
    return xr.DataArray(sub.assessable.values.astype(bool), dims=("pairing", "frequency"),
                        coords={"pairing": sub.pairing.values,
                                "frequency": identified.frequency.values})


def fit_data(identified: xr.Dataset, identifiable: xr.DataArray, pairings: Sequence[Pairing],
             version: str, band: Sequence[float], weight: str) -> list[FrfData]:
    """The identified FRFs to fit, masked to the band and the predicted identifiable band.

    Parameters
    ----------
    identified : xarray.Dataset
        An identify output (``frf_identified_*``, ``frf_identified_{lower,upper}_db``).
    identifiable : xarray.DataArray
        The design step's ``identifiable`` (pairing, frequency) on the same grid, or for a
        bench record :func:`assessable_band`.
    pairings : sequence of Pairing
        The pairings to fit.
    version : str
        Data version (``clean``, ``raw``, ``tsa``, a removal method).
    band : (float, float)
        Fitted band [Hz].
    weight : {"pairing", "bounds", "uniform"}
        See :data:`WEIGHTS`.

    Returns
    -------
    list of FrfData
        One per pairing with at least one fitted frequency (the others are logged).

    Raises
    ------
    DataError
        A pairing that failed identification, grids that differ, a pairing without bounds
        when they weigh the fit, or nothing left to fit.
    """
    f = identified.frequency.values
    if not np.allclose(identifiable.frequency.values, f, rtol=1e-9):
        raise DataError("design step", "its frequency grid differs from the identified "
                                       "FRFs': rerun both with the same identify.frf")
    in_band = (f >= band[0]) & (f <= band[1])
    out = []
    for p in pairings:
        d = identified.isel(model=_model_index(identified, p.name, version))
        if str(d.status.values) == "failed":  # a poor model is still data to fit to
            raise DataError(f"pairing {p.name}, version {version}", f"identification "
                            f"failed ({d.reason.values}): leave it out of fit.pairings")
        no, ni = len(p.outputs), len(p.inputs)
        g = (d.frf_identified_real + 1j * d.frf_identified_imag).values[:, :no, :ni].copy()
        keep = in_band & identifiable.sel(pairing=p.name).values.astype(bool)
        g[~keep] = np.nan
        if not keep.any():
            log.info("%s: not predicted identifiable in %s Hz, left out", p.name, list(band))
            continue
        sigma = None
        if weight != "uniform":
            lo = 10 ** (d.frf_identified_lower_db.values[:, :no, :ni] / 20)
            hi = 10 ** (d.frf_identified_upper_db.values[:, :no, :ni] / 20)
            if not np.all(np.isfinite(lo[keep]) & np.isfinite(hi[keep])):
                raise DataError(f"pairing {p.name}", "its model has no 95 % bounds: bound "
                                "this method (identify.bounds) or set fit.weight: uniform")
            # floor at 1e-6 Np: a jackknife of exactly repeated data has zero spread
            sigma = np.maximum(sigma_from_bounds(lo, hi), 1e-6)
            if weight == "pairing":
                sigma = np.full(g.shape, float(np.median(sigma[keep])))
        out.append(FrfData(p, f, g, sigma))
        log.info("%s: %d frequencies from %.1f to %.1f Hz%s", p.name, int(keep.sum()),
                 f[keep].min(), f[keep].max(), "" if sigma is None else
                 f", sigma median {np.median(sigma[keep]):.2g} Np")
    if not out:
        raise DataError("fit data", f"no pairing is predicted identifiable in {list(band)} "
                                    "Hz: widen fit.band or choose other fit.pairings")
    return out


def nonparametric_data(identified: xr.Dataset, pairings: Sequence[Mapping[str, Any]],
                       version: str, band: Sequence[float], segment: float,
                       motors: Sequence[Motor]) -> list[FrfData]:
    """A bench record's nonparametric FRFs to fit (``fit.data: nonparametric``).

    The identify stage's reference of a bench record is the Welch estimate of the
    conditioned record on its own grid (``frf_reference_*``, 95 % magnitude bounds
    ``frf_reference_{lower,upper}``): through the mapped set-point where the pairing has
    one (``reference``), else H1. Kept where it is coherent and off the order lines
    (``assessable``) and inside ``band``; sigma from its bounds; the estimate's Hann
    ``segment`` [s] and estimator named, and the motor whose torque is the pairing's
    input named as the excitation's entry (the record's excitation is taken to reach the
    chain through that motor's command, so its loop shapes the input's spectrum): the
    fit compares the data with the model's expected estimate (docs/fit.md).

    Raises
    ------
    DataError
        A simulated record (its reference is the true model), a pairing without bounds
        where it is fitted, or nothing coherent in the band.
    """
    if identified.attrs.get("reference") == "truth":
        raise DataError("fit.data", "nonparametric needs a bench record: this record's "
                                    "reference is the true model (fit.data: frf)")
    f = identified.frequency.values
    reach = KERNEL_REACH / segment    # the window kernel's nodes must stay above 0 Hz
    by_input = {m.input: m.name for m in motors if m.controller.type != "none"}
    out = []
    for q in pairings:
        p = Pairing.from_config(q)
        d = identified.isel(model=_model_index(identified, p.name, version))
        no, ni = len(p.outputs), len(p.inputs)
        g = (d.frf_reference_real + 1j * d.frf_reference_imag).values[:, :no, :ni].copy()
        lo = d.frf_reference_lower.values[:, :no, :ni]
        hi = d.frf_reference_upper.values[:, :no, :ni]
        keep = ((f >= band[0]) & (f <= band[1]) & (f > reach)
                & d.assessable.values.astype(bool))
        keep &= np.all(np.isfinite(g) & (lo > 0) & np.isfinite(hi), axis=(1, 2))
        if not keep.any():
            log.info("%s: no coherent estimate in %s Hz, left out", p.name, list(band))
            continue
        g[~keep] = np.nan
        sigma = np.ones(g.shape)        # where the FRF is NaN it weighs nothing
        sigma[keep] = sigma_from_bounds(lo[keep], hi[keep])
        excitation = by_input.get(p.inputs[0]) if ni == 1 else None
        estimator = "reference" if q.get("reference") else "h1"
        out.append(FrfData(p, f, g, sigma, segment, excitation, estimator))
        log.info("%s: %d frequencies from %.1f to %.1f Hz, %s estimate, %g s segments, "
                 "input spectrum %s, sigma median %.2g Np", p.name, int(keep.sum()),
                 f[keep].min(), f[keep].max(), estimator, segment,
                 f"shaped by motor {excitation}'s loop" if excitation else "taken as flat",
                 float(np.median(sigma[keep])))
    if not out:
        raise DataError("fit data", f"no pairing's nonparametric FRF is coherent in "
                                    f"{list(band)} Hz: widen fit.band or record longer")
    return out


def _candidates(data: Sequence[FrfData], cfg: Mapping[str, Any]) -> list[Pairing]:
    # an added sensor (another output of a fitted input) or an added excitation (the
    # other motor's torque to any output): every SISO path not fitted yet; a configured
    # drivetrain offers its own motors and sensors
    used = {(u, y) for d in data for u in d.pairing.inputs for y in d.pairing.outputs}
    inputs, outputs = MOTOR_INPUTS, CANDIDATE_OUTPUTS
    if cfg.get("drivetrain"):
        plant = bench_ss(cfg, closed=False)
        inputs = tuple(u for u in plant.inputs if u.startswith("motor_torque_"))
        outputs = tuple(plant.outputs)
    return [Pairing(f"{u}_to_{y}", (u,), (y,)) for u in inputs
            for y in outputs if (u, y) not in used]


def fit_dataset(result: FitResult, data: Sequence[FrfData], prior_cfg: Mapping[str, Any],
                identified: xr.Dataset, version: str, source: str = "frf") -> xr.Dataset:
    """Everything one fit produced, as a CF dataset (docs/architecture.md, "Data contract").

    Parameters
    ----------
    result : FitResult
    data : sequence of FrfData
        What was fitted.
    prior_cfg : mapping
        The configuration the fit started from.
    identified : xarray.Dataset
        The identify output (for the 95 % bounds drawn with the data).
    version : str
        The fitted data version.
    source : {"frf", "nonparametric"}
        What was fitted (``fit.data``): the identified models' FRFs, or the record's
        Welch estimate (the identify output's ``frf_reference_*``); written as the data.
    """
    pairings = [d.pairing for d in data]
    f = data[0].f_hz
    no = max(len(p.outputs) for p in pairings)
    ni = max(len(p.inputs) for p in pairings)

    def stacked(arrays: Sequence[np.ndarray]) -> np.ndarray:
        # pairings of unequal channel count on common (output, input) dimensions
        return np.stack([pad(a, (f.size, no, ni)) for a in arrays])

    # the data on the whole grid (NaN marks what the fit left out: keep it for the figure)
    rows = [_model_index(identified, p.name, version) for p in pairings]
    full, lower, upper = [], [], []
    for d, row in zip(data, rows, strict=True):
        m = identified.isel(model=row)
        o, i = len(d.pairing.outputs), len(d.pairing.inputs)
        if source == "nonparametric":
            full.append((m.frf_reference_real + 1j * m.frf_reference_imag).values[:, :o, :i])
            # a bound of 0 (an estimate too poor for a lower bound) is no level in dB: NaN
            for bound, out in ((m.frf_reference_lower, lower), (m.frf_reference_upper, upper)):
                b = bound.values[:, :o, :i]
                out.append(20 * np.log10(np.where(b > 0, b, np.nan)))
        else:
            full.append((m.frf_identified_real + 1j * m.frf_identified_imag).values[:, :o, :i])
            lower.append(m.frf_identified_lower_db.values[:, :o, :i])
            upper.append(m.frf_identified_upper_db.values[:, :o, :i])
    what = ("nonparametric (Welch) FRF of the record" if source == "nonparametric"
            else "identified FRF")
    g_data = stacked(full)
    g_prior = stacked(pairing_frf(prior_cfg, pairings, f))
    g_fit = stacked(pairing_frf(result.config, pairings, f))
    fitted = np.stack([d.mask.any(axis=(1, 2)) for d in data])
    if result.delay:    # the fitted model as the data see it: with the fitted delay
        g_fit = g_fit * np.exp(-2j * np.pi * f * result.delay)[None, :, None, None]
    # design help from the fit's own information (its frequencies, weights and noise
    # scale; the delay held), each candidate added at the fitted data's typical noise
    n = len(result.free)
    w, v = np.linalg.eigh(result.identifiability.fisher[:n, :n])
    candidates = _candidates(data, result.config)
    design = design_outputs(result.config, result.free, pairings, candidates, f,
                            sigma=max(result.noise_scale * float(np.median(
                                [np.median(1 / d.weight) for d in data])), 1e-6),
                            base=(v * np.sqrt(np.clip(w, 0.0, None))).T)
    fdim = ("pairing", "frequency", "output", "input")
    v, c, attrs = result_variables(result, prior_cfg)
    v.update({
        "delay": cf_var((), result.delay, "s", "fitted input-to-output delay"),
        "delay_lower": cf_var((), result.delay_interval[0], "s",
                           "lower end of the delay's 95 % interval"),
        "delay_upper": cf_var((), result.delay_interval[1], "s",
                           "upper end of the delay's 95 % interval"),
        "fitted": cf_var(("pairing", "frequency"), fitted, "1",
                      "frequency entered the fit (in band, predicted identifiable)"),
        "frf_data_real": cf_var(fdim, g_data.real, "mixed (see frf_unit)",
                             f"{what} (the data), real part"),
        "frf_data_imag": cf_var(fdim, g_data.imag, "mixed (see frf_unit)",
                             f"{what} (the data), imaginary part"),
        "frf_data_lower_db": cf_var(fdim, stacked(lower), "dB",
                                 f"95 % lower bound of the magnitude of the {what}"),
        "frf_data_upper_db": cf_var(fdim, stacked(upper), "dB",
                                 f"95 % upper bound of the magnitude of the {what}"),
        "frf_prior_real": cf_var(fdim, g_prior.real, "mixed (see frf_unit)",
                              "model FRF at the prior, real part"),
        "frf_prior_imag": cf_var(fdim, g_prior.imag, "mixed (see frf_unit)",
                              "model FRF at the prior, imaginary part"),
        "frf_fitted_real": cf_var(fdim, g_fit.real, "mixed (see frf_unit)",
                               "fitted model FRF (with the fitted delay), real part"),
        "frf_fitted_imag": cf_var(fdim, g_fit.imag, "mixed (see frf_unit)",
                               "fitted model FRF (with the fitted delay), imaginary part"),
        "design_rank": cf_var(("candidate",), [r["rank"] for r in design], "1",
                           "determined directions with the candidate output added"),
        "design_identifiable": cf_var(("candidate",), np.array(
            [", ".join(r["identifiable"]) for r in design]), "1",
            "free parameters the data would determine with the candidate added"),
    })
    c.update({
        "pairing": cf_var(("pairing",), np.array([p.name for p in pairings]), "1",
                       "fitted pairing"),
        "frequency": cf_var(("frequency",), f, "Hz", "frequency"),
        "output": cf_var(("output",), np.arange(no), "1", "output index"),
        "input": cf_var(("input",), np.arange(ni), "1", "input index"),
        "frf_unit": cf_var(("pairing",), identified.frf_unit.values[rows].astype(str), "1",
                        "unit of each pairing's FRF"),
        "candidate": cf_var(("candidate",), np.array(
            ["(as fitted)" if r["added"] is None else r["added"] for r in design]), "1",
            "output added by the design help (first: none)"),
    })
    return xr.Dataset(v, coords=c, attrs={**attrs, "data": source, "version": version})


def fit_record(cfg: Mapping[str, Any], prior: Mapping[str, Any], *,
               identified: xr.Dataset | None = None, design: xr.Dataset | None = None,
               modes_file: str | None = None) -> tuple[FitResult, xr.Dataset]:
    """One record's fit (rule ``fit``): the data, the fit, its log and its dataset.

    Parameters
    ----------
    cfg : mapping
        The rule's config slice: ``fit``, ``pairings`` (of ``identify``), ``seed``,
        ``segment`` (``identify.nonparametric.segment``, for ``fit.data: nonparametric``).
    prior : mapping
        The configuration the fit starts from (``fit.start`` merged).
    identified : xarray.Dataset, optional
        The record's identify output (``fit.data: frf`` or ``nonparametric``).
    design : xarray.Dataset, optional
        The design output of a simulated record: its predicted identifiable band. A bench
        record (None) is fitted where its nonparametric FRF is coherent.
    modes_file : str, optional
        The modal table (``fit.data: modes``).

    Returns
    -------
    result : FitResult
    dataset : xarray.Dataset
        :func:`fit_dataset` or :func:`gbpipe.model.modal_fit_dataset`.
    """
    fit = cfg["fit"]
    pairings = [Pairing.from_config(q) for q in cfg["pairings"]]
    common = {"bounds": fit["bounds"], "factor": fit["factor"], "n_starts": fit["starts"],
              "seed": cfg["seed"], "search": fit["search"], "alpha": fit["alpha"],
              "accuracy": fit["accuracy"]}
    if fit["data"] == "modes":
        m = fit["modes"]
        system = next((q for q in pairings if q.name == m["system"]), None)
        data = read_modes_table(modes_file, m["pairing"], m["method"], system,
                                tuple(m["band"]))
        log.info("fitting %s from the prior (fit.start) to %d modes of %s (%s)",
                 ", ".join(fit["free"]), data.frequency_hz.size, modes_file, m["system"])
        res = fit_parameters(prior, data, fit["free"], **common)
    else:
        if fit["data"] == "nonparametric":
            data = nonparametric_data(identified, cfg["pairings"], fit["version"],
                                      fit["band"], float(cfg["segment"]),
                                      bench_chain(prior).motors)
        else:
            band = (design.identifiable.sel(version=fit["version"]) if design is not None
                    else assessable_band(identified, fit["version"]))
            data = fit_data(identified, band, pairings, fit["version"], fit["band"],
                            fit["weight"])
        log.info("fitting %s from the prior (fit.start) to %d pairings, version %s",
                 ", ".join(fit["free"]), len(data), fit["version"])
        res = fit_parameters(prior, data, fit["free"], delay=fit["delay"],
                             max_delay=fit["max_delay"], **common)
        if fit["jackknife"]:
            res = jackknife_intervals(res, data, fit["jackknife"], delay=fit["delay"],
                                      max_delay=fit["max_delay"])
    log.info("cost %.4g at the prior, %.4g fitted, %d model evaluations (%s)\n%s",
             res.cost_prior, res.cost, res.n_evaluations, res.search, res.table())
    g = res.goodness
    # a poor fit and one nothing could test both leave their parameters unvouched for
    (log.info if g.status == "passed" else log.warning)("goodness of fit: %s: %s",
                                                        g.status, g.reason)
    for name, share, count in zip(g.groups, g.group_share, g.group_count_share,
                                  strict=True):
        log.info("  %s: %.1f %% of chi2 (%.1f %% of the residuals)", name, 100 * share,
                 100 * count)
    for k, share in enumerate(g.band_share):
        log.info("  %.4g-%.4g Hz: %.1f %% of chi2 (%.1f %% of the residuals)",
                 g.band_edges[k], g.band_edges[k + 1], 100 * share,
                 100 * g.band_count_share[k])
    ds = (modal_fit_dataset(res, m["system"], prior) if fit["data"] == "modes"
          else fit_dataset(res, data, prior, identified, fit["version"], fit["data"]))
    if "design_rank" in ds:
        for added, rank, names in zip(ds.candidate.values, ds.design_rank.values,
                                      ds.design_identifiable.values, strict=True):
            log.info("design help: %s -> %d of %d directions determined (%s)", added,
                     rank, len(fit["free"]), names or "none")
    return res, ds
