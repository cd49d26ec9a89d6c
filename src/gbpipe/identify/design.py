"""Predicted identifiable band of each pairing, before identification runs (design step).

From the closed-loop bench's frequency responses (every source -> every recorded signal),
the true model ``G`` of each pairing, the spectra of the sources (set-point excitation,
motor ripple) and the sensor noise, per pairing and frequency:

1. **Split the output.** Every recorded signal is a response to the sources ``s``
   (``speed_ref``, ``torque_ref``, ``disturbance_driver``, ``disturbance_driven``, and the
   angle-locked gear excitation ``te_*``, ``misalign_*``) plus its own sensor noise:
   ``u = T_u s + n_u``, ``y = T_y s + n_y``. The part of ``y`` that the model ``G`` does
   not explain is ``v = y − G u = (T_y − G T_u) s + n_y − G n_u``. A source whose
   ``T_y − G T_u`` is zero at every frequency (to rounding) reaches the outputs only
   through the pairing's inputs: it *excites* the pairing (a set-point on the own motor's
   loop, the own motor's ripple). Every other source is *disturbance*: it reaches ``y`` by
   another path (the other motor's ripple, the other loop's set-point, the gear
   excitation) and enters ``u`` only by feedback, so it adds to the noise and nothing to
   the excitation.
2. **Spectra.** ``Φ_u^r = Σ_exc T_u Φ_s T_uᴴ`` (input spectrum due to the exciting
   sources) and ``Φ_v = Σ_dist |T_y − G T_u|² Φ_s + Φ_ny + |G|² Φ_nu`` (diagonal).
3. **Variance** of a direct closed-loop estimate of order ``n`` from ``N`` samples (Ljung,
   *System Identification*, 2nd ed., 1999, sec. 9.4 eq. 9.62 and sec. 13.4; consistent
   when the noise model is flexible, as the subspace methods' innovation form is):
   ``Cov vec Ĝ ≈ (n / N) (Φ_u^r)^{−T} ⊗ Φ_v``, so element ``(i, j)`` has
   ``Var Ĝ_ij = (n / N) [(Φ_u^r)^{−1}]_jj Φ_v,ii``. With the element SNR
   ``ρ_ij = |G_ij|² / ([(Φ_u^r)^{−1}]_jj Φ_v,ii)`` the relative error std is
   ``σ_ij = sqrt((n / N) / ρ_ij)`` and the expected (partial, for several inputs;
   Bendat & Piersol, *Random Data*, 4th ed., 2010, sec. 7.3) coherence
   ``γ²_ij = ρ_ij / (1 + ρ_ij)`` — for one input, ``|G|² Φ_u^r / (|G|² Φ_u^r + Φ_v)``.
4. **Magnitude error.** ``Ĝ / G = 1 + δ`` with ``δ`` circular complex Gaussian,
   ``E|δ|² = σ²``; to first order ``|Ĝ / G| = 1 + Re δ`` with ``Re δ ~ N(0, σ² / 2)``, so
   the 95 % bound of the magnitude error ``|20 log10 |Ĝ / G||`` (the metric of
   :func:`gbpipe.identify.frf_error_db`) is ``−20 log10(1 − 1.96 σ / √2)`` (the lower
   side, the larger; infinite when ``1.96 σ / √2 >= 1``).
5. **Band.** A frequency is identifiable when every element's bound is within
   ``identify.tolerance_db``; the predicted band is :func:`gbpipe.identify.match_bandwidth`
   of the bound (highest grid frequency up to which all points pass), the full mask is
   kept so non-contiguous bands show.

:func:`predict_test` does this once per data version (:func:`version_cycles`): ``raw``
with every gear-excitation line, a harmonic-removal version without the lines its cycles
take off, ``clean`` without gear excitation (and, as a reference, with the measured-like
sensor noise: see its Notes).

Bias from sensor noise on the inputs (errors in variables) is ``Φ_nu / Φ_u`` relative, below
1e-3 for the configured torque sensors, and not modelled. See docs/design.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.identify.metrics import match_bandwidth
from gbpipe.identify.spectra_model import (
    excitation_psds,
    reference_psd,
    ripple_psd,
    sensor_psds,
)
from gbpipe.kinematics import order_of
from gbpipe.lti import NamedSS, frf
from gbpipe.units import squared_units

__all__ = ["SOURCES", "Z95", "EXACT", "error_bound_db", "pairing_prediction", "predict",
           "predict_test", "version_cycles"]

#: Inputs of the closed-loop bench (:func:`gbpipe.model.bench_ss`) that carry random or
#: designed signals: the set-points and the motor-torque disturbances (ripple)
SOURCES = ("speed_ref", "torque_ref", "disturbance_driver", "disturbance_driven")
#: unit of a recorded signal -> its sensor kind in ``noise.sensor``
_KIND = {"rad/s": "speed", "N m": "torque"}

#: two-sided 95 % point of the standard normal distribution
Z95 = 1.959963984540054
#: relative size below which a source's path to ``v`` counts as zero (rounding of the
#: batched FRF solves is ~1e-12 of the largest term)
EXACT = 1e-7


def error_bound_db(sigma_rel: np.ndarray) -> np.ndarray:
    """95 % bound [dB] of the FRF magnitude error for a relative error std ``sigma_rel``.

    ``−20 log10(1 − 1.96 σ / √2)``, ``inf`` when ``1.96 σ / √2 >= 1`` (module docstring,
    step 4).
    """
    x = Z95 * np.asarray(sigma_rel, dtype=float) / np.sqrt(2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x < 1.0, -20.0 * np.log10(np.clip(1.0 - x, 1e-300, None)), np.inf)


def _inverse_diagonal(phi: np.ndarray) -> np.ndarray:
    """Diagonal of ``phi⁻¹`` per frequency, ``inf`` where ``phi`` is (numerically)
    singular: an input with no excitation of its own there."""
    nf, nu, _ = phi.shape
    out = np.full((nf, nu), np.inf)
    scale = np.max(np.abs(phi), axis=(1, 2))
    ok = scale > 0
    if nu > 1 and ok.any():
        ok[ok] = np.linalg.cond(phi[ok]) < 1e12
    if ok.any():
        out[ok] = np.real(np.diagonal(np.linalg.inv(phi[ok]), axis1=1, axis2=2))
    return out


def pairing_prediction(t_u: np.ndarray, t_y: np.ndarray, g: np.ndarray,
                       source_psd: np.ndarray, u_noise: np.ndarray, y_noise: np.ndarray,
                       n_over_n: float) -> dict[str, np.ndarray]:
    """Predicted SNR, coherence and FRF error std of one pairing (module docstring).

    Parameters
    ----------
    t_u, t_y : ndarray, complex, shape (nf, nu, ns), (nf, ny, ns)
        Closed-loop FRFs from the ``ns`` sources to the pairing's inputs and outputs.
    g : ndarray, complex, shape (nf, ny, nu)
        True model of the pairing.
    source_psd : ndarray, shape (nf, ns)
        One-sided PSD of each source [its unit² / Hz]; sources are independent.
    u_noise, y_noise : ndarray, shape (nf, nu), (nf, ny)
        Sensor noise PSD of each input and output [unit² / Hz].
    n_over_n : float
        Model order over samples, ``n / N``.

    Returns
    -------
    dict
        ``snr`` (nf, ny): excitation-driven over unexplained output power [1];
        ``coherence`` (nf, ny, nu) [1]; ``sigma`` (nf, ny, nu): relative error std [1];
        ``exciting`` (ns,): bool, the sources that excite the pairing;
        ``input_psd`` (nf, nu): diagonal of ``Φ_u^r`` [input unit² / Hz];
        ``disturbance_share`` (nf, ny, ns + 2): share of ``Φ_v`` from each source, the
        output's sensor noise and the inputs' sensor noise [1];
        ``share`` (ns,): each source's share of the excitation-driven input power summed
        over the grid [1] (0 for a disturbance).
    """
    gt_u = g @ t_u
    t_v = t_y - gt_u
    size = np.maximum(np.abs(t_y).max(axis=(0, 1)), np.abs(gt_u).max(axis=(0, 1)))
    exciting = np.abs(t_v).max(axis=(0, 1)) <= EXACT * size
    w_exc = source_psd * exciting
    phi_u = np.einsum("fis,fs,fjs->fij", t_u, w_exc, t_u.conj())
    power = np.einsum("fis,fs->s", np.abs(t_u) ** 2, w_exc)
    share = power / power.sum() if power.sum() > 0 else power
    # the terms of Φ_v: each disturbing source, the output's and the inputs' sensor noise
    terms = np.concatenate([
        np.abs(t_v) ** 2 * (source_psd * ~exciting)[:, None, :], y_noise[:, :, None],
        np.einsum("fij,fj->fi", np.abs(g) ** 2, u_noise)[:, :, None]], axis=2)
    phi_v = terms.sum(axis=2)
    inv_diag = _inverse_diagonal(phi_u)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.abs(g) ** 2 / (inv_diag[:, None, :] * phi_v[:, :, None])
        snr = np.real(np.einsum("fij,fjk,fik->fi", g, phi_u, g.conj())) / phi_v
        coherence = np.where(np.isinf(rho), 1.0, rho / (1.0 + rho))
        sigma = np.sqrt(n_over_n / rho)
    return {"snr": snr, "coherence": coherence, "sigma": sigma, "exciting": exciting,
            "share": share, "input_psd": np.real(np.diagonal(phi_u, axis1=1, axis2=2)),
            "disturbance_share": terms / np.where(phi_v > 0, phi_v, 1.0)[:, :, None]}


def predict(t_frf: np.ndarray, signals: Sequence[str], sources: Sequence[str],
            pairings: Sequence[Mapping[str, Any]], truths: Mapping[str, np.ndarray],
            source_psd: Mapping[str, np.ndarray], sensor_psd: Mapping[str, np.ndarray],
            f_hz: np.ndarray, order: int, n_samples: int, tolerance_db: float,
            input_unit: str = "N m") -> xr.Dataset:
    """Predicted SNR, coherence, FRF error and identifiable band of every pairing.

    Parameters
    ----------
    t_frf : ndarray, complex, shape (nf, len(signals), len(sources))
        Closed-loop bench FRFs from each source to each recorded signal.
    signals, sources : sequence of str
        Names of the rows and columns of ``t_frf``.
    pairings : sequence of mapping
        ``identify.pairings`` (``name``, ``inputs``, ``outputs``).
    truths : mapping
        Pairing name -> true FRF, shape (nf, n_outputs, n_inputs).
    source_psd, sensor_psd : mapping
        Source name -> PSD (missing: 0), signal name -> sensor noise PSD [unit² / Hz].
    f_hz : ndarray
        Grid [Hz] (``identify.frf``).
    order : int
        Model order ``n`` the identify stage fits.
    n_samples : int
        Samples ``N`` of the record at ``identify.sample_rate``.
    tolerance_db : float
        ``identify.tolerance_db`` [dB].
    input_unit : str
        Unit of every pairing input (the motor torques: N m).

    Returns
    -------
    xarray.Dataset
        On (pairing, frequency, output, input), padded with NaN: ``snr_db`` (pairing,
        frequency, output) [dB], ``coherence`` [1], ``predicted_error_db`` [dB],
        ``identifiable`` (pairing, frequency) [1] (0/1), ``predicted_hz`` (pairing) [Hz],
        ``input_psd`` (pairing, frequency, input) [input unit² / Hz],
        ``excitation_share`` (pairing, source) [1], ``disturbance_share`` (pairing,
        frequency, output, term) [1] (what limits the band).
    """
    f = np.asarray(f_hz, dtype=float)
    nf = f.size
    zero = np.zeros(nf)
    psd = np.column_stack([np.asarray(source_psd.get(s, zero), float) for s in sources])
    n_p = len(pairings)
    n_o = max(len(p["outputs"]) for p in pairings)
    n_i = max(len(p["inputs"]) for p in pairings)
    snr = np.full((n_p, nf, n_o), np.nan)
    coh, err = np.full((n_p, nf, n_o, n_i), np.nan), np.full((n_p, nf, n_o, n_i), np.nan)
    mask, band = np.zeros((n_p, nf), dtype=int), np.zeros(n_p)
    out_name, in_name = np.full((n_p, n_o), "", dtype=object), np.full((n_p, n_i), "",
                                                                         dtype=object)
    share, in_psd = np.zeros((n_p, len(sources))), np.full((n_p, nf, n_i), np.nan)
    terms = [*sources, "sensor_output", "sensor_input"]
    dist = np.full((n_p, nf, n_o, len(terms)), np.nan)
    for k, p in enumerate(pairings):
        ins, outs = list(p["inputs"]), list(p["outputs"])
        rows_u = [list(signals).index(s) for s in ins]
        rows_y = [list(signals).index(s) for s in outs]
        res = pairing_prediction(
            t_frf[:, rows_u], t_frf[:, rows_y], np.asarray(truths[p["name"]]), psd,
            np.column_stack([sensor_psd.get(s, zero) for s in ins]),
            np.column_stack([sensor_psd.get(s, zero) for s in outs]),
            float(order) / float(n_samples))
        e = error_bound_db(res["sigma"])
        with np.errstate(divide="ignore"):
            snr[k, :, :len(outs)] = 10.0 * np.log10(res["snr"])
        coh[k, :, :len(outs), :len(ins)] = res["coherence"]
        err[k, :, :len(outs), :len(ins)] = e
        mask[k] = np.all(e <= tolerance_db, axis=(1, 2))
        band[k] = match_bandwidth(f, e, tolerance_db)
        out_name[k, :len(outs)], in_name[k, :len(ins)] = outs, ins
        share[k], in_psd[k, :, :len(ins)] = res["share"], res["input_psd"]
        dist[k, :, :len(outs)] = res["disturbance_share"]
    names = [str(p["name"]) for p in pairings]
    elem = ("pairing", "frequency", "output", "input")
    return xr.Dataset(
        {
            "snr_db": (("pairing", "frequency", "output"), snr, {
                "units": "dB", "long_name": "predicted output SNR: output power driven by "
                "the exciting sources over the power the pairing's inputs do not explain"}),
            "coherence": (elem, coh, {
                "units": "1", "long_name": "expected (partial) coherence of input and "
                "output due to the exciting sources"}),
            "predicted_error_db": (elem, err, {
                "units": "dB", "long_name": "predicted 95 % bound of the identified FRF "
                "magnitude error"}),
            "identifiable": (("pairing", "frequency"), mask, {
                "units": "1", "long_name": "every element's predicted error within "
                "identify.tolerance_db (1) or not (0)"}),
            "predicted_hz": (("pairing",), band, {
                "units": "Hz", "long_name": "predicted match bandwidth: highest frequency "
                "up to which every grid point is identifiable"}),
            "input_psd": (("pairing", "frequency", "input"), in_psd, {
                "units": squared_units(input_unit) + " Hz-1", "long_name": "one-sided PSD of "
                "the input due to the exciting sources"}),
            "disturbance_share": (("pairing", "frequency", "output", "term"), dist, {
                "units": "1", "long_name": "share of the unexplained output PSD from each "
                "disturbing source and the sensor noise"}),
            "excitation_share": (("pairing", "source"), share, {
                "units": "1", "long_name": "share of the excitation-driven input power "
                "from each source (0: the source is a disturbance of the pairing)"}),
        },
        coords={
            "pairing": ("pairing", names, {"units": "1", "long_name": "signal pairing"}),
            "frequency": ("frequency", f, {"units": "Hz", "long_name": "frequency"}),
            "output": ("output", np.arange(n_o), {"units": "1", "long_name": "output index"}),
            "input": ("input", np.arange(n_i), {"units": "1", "long_name": "input index"}),
            "source": ("source", list(sources), {"units": "1", "long_name": "closed-loop "
                                                 "bench input carrying a random or designed "
                                                 "signal"}),
            "term": ("term", terms, {"units": "1", "long_name": "term of the unexplained "
                                     "output: a source, or the sensor noise of the output "
                                     "or of the inputs"}),
            "output_name": (("pairing", "output"), out_name.astype(str),
                            {"units": "1", "long_name": "output signal"}),
            "input_name": (("pairing", "input"), in_name.astype(str),
                           {"units": "1", "long_name": "input signal"}),
        },
        attrs={"order": int(order), "n_samples": int(n_samples),
               "tolerance_db": float(tolerance_db)},
    )


def version_cycles(cfg: Mapping[str, Any], version: str) -> list[Fraction] | None:
    """Cycle orders [HSS orders] whose lines a data version has taken off.

    ``None`` for ``clean`` (no gear excitation at all), ``[]`` for ``raw`` (measured-like,
    every line), the orders of ``tsa.tests`` for ``tsa``, those of ``removal.tests`` for a
    removal method (the ``removal_tests`` stage takes off the families of those cycles).
    """
    if version == "clean":
        return None
    if version == "raw":
        return []
    names = cfg["tsa"]["tests"] if version == "tsa" else cfg["removal"]["tests"]
    return [order_of(cfg["gearbox"]["stages"], c) for c in names]


def predict_test(cfg: Mapping[str, Any], closed: NamedSS, truths: Mapping[str, NamedSS],
                 speed_ref: np.ndarray, torque_ref: np.ndarray, fs: float,
                 resolution: float = 1.0) -> xr.Dataset:
    """The prediction of :func:`predict` for one test and every data version.

    Parameters
    ----------
    cfg : mapping
        Validated configuration: ``gearbox.stages``, ``excitation``, ``noise``
        (``motor_ripple``, ``sensor``, ``encoder``; a ``drivetrain``'s motors their own
        ``ripple``), ``tsa.tests``, ``removal.tests`` and
        ``identify`` (``pairings``, ``versions``, ``frf``, ``sample_rate``, ``order`` and
        ``max_order``, ``tolerance_db``).
    closed : NamedSS
        The closed-loop bench (:func:`gbpipe.model.bench_ss`): inputs :data:`SOURCES` and
        the angle-locked excitation ``te_*``, ``misalign_*``.
    truths : mapping
        Pairing name -> its true model (:func:`gbpipe.model.truth_model`).
    speed_ref, torque_ref : ndarray
        The test's set-points [rad/s], [N·m] (designed excitation included), at ``fs``.
    fs : float
        Sample rate of the set-points and of the recorded noise [Hz]
        (``campaign.sample_rate``).
    resolution : float
        Frequency resolution [Hz] of the set-point spectra (and of a line's width).

    Returns
    -------
    xarray.Dataset
        As :func:`predict`, along a first dimension ``version`` (``identify.versions``):
        ``raw`` with the sensor noise and every gear-excitation line, a harmonic-removal
        version without the lines its cycles take off (:func:`version_cycles`), ``clean``
        with the sensor noise and no gear excitation; attributes also give the record
        length [s].

    Notes
    -----
    Clean records carry no sensor noise, and the variance limit of noise-free data is
    unbounded: it would call every excited pairing identifiable to the top of the grid,
    where what limits a clean fit is the estimator's bias, which no prediction here
    models (docs/design.md). The clean rows are therefore predicted with the measured-like
    sensor noise and no gear lines: the band the measured counterpart reaches with every
    line removed.
    """
    idc, noise = cfg["identify"], cfg["noise"]
    grid = idc["frf"]
    f = np.geomspace(float(grid["f_min"]), float(grid["f_max"]), int(grid["points"]))
    signals = sorted({s for p in idc["pairings"] for s in (*p["inputs"], *p["outputs"])})
    locked = [s for s in closed.inputs if s.startswith(("te_", "misalign_"))]
    # the paper's SOURCES, or a drivetrain's references and one disturbance per motor
    motors = [s.removeprefix("disturbance_") for s in closed.inputs
              if s.startswith("disturbance_")]
    sources = [*SOURCES[:2], *(f"disturbance_{m}" for m in motors), *locked]
    t_frf = frf(closed.select(sources, signals), f)
    rotation = (float(np.min(speed_ref)) / (2 * np.pi), float(np.max(speed_ref)) / (2 * np.pi))
    # the simulator scales every gear-excitation amplitude with the braking-torque set-point
    load = float(np.sqrt(np.mean((torque_ref / float(cfg["excitation"]["load_reference"]))
                                 ** 2)))
    set_points = {"speed_ref": reference_psd(speed_ref, fs, f, resolution),
                  "torque_ref": reference_psd(torque_ref, fs, f, resolution)}
    kinds = {s: _KIND[closed.units[s]] for s in signals}
    sensor = sensor_psds(noise, kinds, fs, f)
    order = idc["order"] if isinstance(idc["order"], int) else idc["max_order"]
    duration = speed_ref.size / fs
    n_samples = int(round(duration * float(idc["sample_rate"])))
    g = {p["name"]: frf(truths[p["name"]], f) for p in idc["pairings"]}
    # a drivetrain's motor carries its ripple in its own entry, the paper's in noise
    if cfg.get("drivetrain"):
        ripple = {m["name"]: (m["ripple"], f"drivetrain.motors[{i}].ripple")
                  for i, m in enumerate(cfg["drivetrain"]["motors"])}
    else:
        ripple = {m: (spec, f"noise.motor_ripple.{m}")
                  for m, spec in noise["motor_ripple"].items()}
    per_version = []
    for version in idc["versions"]:
        cycles = version_cycles(cfg, version)
        removed = cycles or []
        source_psd = {
            **set_points,
            **{f"disturbance_{m}": ripple_psd(ripple[m][0], fs, f, rotation, resolution,
                                              ripple[m][1], removed)
               for m in motors},
            # clean data have no gear excitation (the simulator adds it to the measured-like
            # signals only); their sensor noise: the Notes
            **({} if cycles is None else excitation_psds(
                cfg["excitation"], cfg["gearbox"]["stages"], locked, f, rotation, load,
                resolution, removed)),
        }
        per_version.append(predict(t_frf, signals, sources, idc["pairings"], g, source_psd,
                                   sensor, f, int(order), n_samples,
                                   float(idc["tolerance_db"])))
    ds = xr.concat(per_version, dim="version", coords="minimal", compat="override",
                   join="exact", combine_attrs="override")
    ds = ds.assign_coords(version=("version", list(idc["versions"]), {
        "units": "1", "long_name": "identification data version (clean, raw, or after a "
                                   "harmonic removal)"}))
    ds.attrs["duration"] = duration
    return ds
