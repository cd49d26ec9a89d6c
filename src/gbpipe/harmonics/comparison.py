"""The removal-comparison stage: every harmonic-removal method on the same sweep, scored
by the exact separation metric.

* :func:`method_params` -- a method's keyword arguments from the ``removal`` config
  section, fitted to the families at hand;
* :func:`record_params` -- those of one record: the regression's second angle (the twist
  of the second line-carrying shaft against the tachometer's, from the record's speeds);
* :func:`compare_method` -- rule ``removal``: one method on the sweep and on its known
  harmonic part (its wall time and memory logged), and
  :func:`gbpipe.harmonics.separation_metrics` against the random-only sweep;
* :func:`removal_rows` -- rule ``removal_table``: one row per method x family x rpm bin x
  band;
* :func:`method_residuals` -- rule ``removal_tests``: the measured-like signals of a test
  after one method (one signal at a time but for the regression), for identification
  (the version named after the method), and
  :func:`record_separation`, the same exact metric on them against the random-only test.

The random-only sweep is the same simulation with every excitation amplitude at zero
(:func:`gbpipe.simulate.random_only`): ``sweep - random_only`` is the harmonic part.
"""

from __future__ import annotations

import logging
import time
import tracemalloc
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import ConfigError, DataError
from gbpipe.harmonics.crossings import crossing_lines
from gbpipe.harmonics.metrics import Families
from gbpipe.harmonics.regression import family_groups
from gbpipe.harmonics.removal import MULTICHANNEL, channel_groups, remove_harmonics
from gbpipe.harmonics.separation import separation_metrics
from gbpipe.harmonics.shaft_angles import shaft_twist
from gbpipe.harmonics.stage import envelope_modes, split_residuals, watched_modes
from gbpipe.io import longest_segment, measured_signal
from gbpipe.progress import Progress

__all__ = ["method_params", "record_params", "compare_method", "removal_rows", "method_residuals",
           "harmonic_record", "record_separation"]

log = logging.getLogger(__name__)


def method_params(removal_cfg: Mapping[str, Any], method: str, families: Families,
                  modes: np.ndarray | None = None) -> dict[str, Any]:
    """Keyword arguments of ``method`` from ``cfg["removal"][method]``.

    A per-family ``knot_spacing`` of the regression keeps the families at hand (and
    ``default``): the tests remove fewer families than the sweep. The regression's
    ``modal_envelope`` becomes its ``modes``: ``modes`` (frequency [Hz], damping ratio
    [-]; :func:`gbpipe.harmonics.envelope_modes` of the bench model), for every family but
    ``motor`` (``modal_families``).

    Raises
    ------
    ValueError
        ``modal_envelope`` is on and no ``modes`` are given.
    """
    params = dict(removal_cfg[method])
    spacing = params.get("knot_spacing")
    if isinstance(spacing, Mapping):
        params["knot_spacing"] = {k: v for k, v in spacing.items()
                                  if k in families or k == "default"}
    if params.pop("modal_envelope", False):
        if modes is None:
            raise ValueError("removal.regression.modal_envelope needs the bench modes: "
                             "pass envelope_modes(bench, spectra) as modes")
        params["modes"] = np.asarray(modes, dtype=float)
        # the carrier's one coefficient needs a constant excitation: the gear and shaft
        # excitation is; the converters' pulsating torque follows the operating point
        # (on the ramp tests' steps a carrier left 31-34 dB of it, its envelope 43-56 dB).
        # Carriers only in the last (coarsest) knot group: an earlier group's carriers
        # would meet the later groups' lines unfitted (residual_regression, ``modes``)
        spacing = params.get("knot_spacing")
        last = family_groups(families, spacing)[-1][1] if isinstance(spacing, Mapping) else families
        params["modal_families"] = [f for f in last if f != "motor"]
    return params


def record_params(params: Mapping[str, Any], record: xr.Dataset) -> dict[str, Any]:
    """A method's keyword arguments for one record: the regression's ``second_angle``
    (the speed signals of the tachometer's shaft and of the second line-carrying shaft)
    becomes its ``twist`` (:func:`gbpipe.harmonics.shaft_twist` of the record's measured
    speeds, rigid ratio 1: the two HSS of the back-to-back bench); an empty one, none.

    Raises
    ------
    ConfigError
        ``removal.regression.second_angle`` names a signal the record does not hold.
    """
    out = dict(params)
    speeds = out.pop("second_angle", None)
    if not speeds:
        return out
    try:
        tacho, other = (np.asarray(measured_signal(record, s).values, dtype=float)
                        for s in speeds)
    except DataError as err:
        raise ConfigError("removal.regression.second_angle",
                          f"{list(speeds)}: {err}; name the speed signals of the "
                          "tachometer's shaft and of the second shaft, or [] for none") from err
    out["twist"] = shaft_twist(tacho, other, float(record.attrs["sample_rate"]))
    return out


def compare_method(sweep: xr.Dataset, random_only: xr.Dataset, bench: xr.Dataset,
                   method: str, params: Mapping[str, Any], families: Families,
                   spec: Mapping[str, Any]) -> xr.Dataset:
    """One removal method on the sweep, scored against the random-only sweep.

    Parameters
    ----------
    sweep, random_only : xarray.Dataset
        The sweep and the same simulation without the angle-locked excitation
        (``spec["signal"]``, ``pulse_time`` [s], attributes ``sample_rate``,
        ``pulses_per_rev``); the pulses of ``sweep`` are used for both.
    bench : xarray.Dataset
        The bench model output (``closed_mode_frequency`` [Hz], ``closed_mode_damping``
        [-]): the modes to watch and their half-power bands.
    method : str
        A name of :data:`gbpipe.harmonics.removal.METHODS`.
    params : mapping
        The method's keyword arguments (:func:`method_params`).
    families : mapping str -> orders
        The families removed [HSS orders] (:func:`gbpipe.harmonics.excitation_families`).
    spec : mapping
        ``cfg["spectra"]``: ``signal``, ``metric_rpm_bins``, ``mode_half_width``,
        ``mode_max_frequency``, ``max_frequency``.

    Returns
    -------
    xarray.Dataset
        :func:`gbpipe.harmonics.separation_metrics` (with ``leftover_db``),
        ``crossing_order`` [HSS orders] and ``crossing_mode`` [Hz] (family, band, rpm:
        :func:`gbpipe.harmonics.crossings.crossing_lines`), the residual
        (time) in the unit of the signal, and attributes ``method``, ``params``,
        ``families`` and ``signal``. The method's wall time [s] and traced peak memory
        [MB] go to the log, not into the result: the same config gives the same file
        (a :data:`gbpipe.harmonics.removal.MULTICHANNEL` method runs on the sweep and
        its harmonic part in one call: both figures are then the pair's).

    Raises
    ------
    DataError
        The two sweeps differ in length or sample rate (not the same simulation).
    """
    name = spec["signal"]
    sig = sweep[name]
    x = np.asarray(sig.values, dtype=float)
    n = np.asarray(random_only[name].values, dtype=float)
    fs = float(sweep.attrs["sample_rate"])
    if n.shape != x.shape or float(random_only.attrs["sample_rate"]) != fs:
        raise DataError("random-only sweep", f"has {n.size} samples at "
                        f"{random_only.attrs['sample_rate']} Hz, the sweep {x.size} at {fs} Hz:"
                        " simulate both from the same config (rule sweep)")
    pulses = np.asarray(sweep.pulse_time.values, dtype=float)
    ppr = int(sweep.attrs["pulses_per_rev"])
    modes = watched_modes(bench, spec)
    log.info("%s on %d samples, families %s, params %s", method, x.size, list(families),
             dict(params))
    run = record_params(params, sweep)  # the second angle from the sweep's own speeds
    h = x - n
    pair = method in MULTICHANNEL
    start = time.perf_counter()
    if pair:
        # the sweep and its harmonic part in one call: the regressors and the factor built
        # once for both, each residual as its own call gives it; time and traced peak
        # memory (numpy allocates through tracemalloc) are then those of the pair
        tracemalloc.start()
        r, rh = remove_harmonics(method, np.stack([x, h])[:, :, None], fs, pulses, families,
                                 ppr, **run)[:, :, 0]
    else:
        r = remove_harmonics(method, x, fs, pulses, families, ppr, **run)
        # the second run (on the harmonic part) is traced
        tracemalloc.start()
    runtime = time.perf_counter() - start
    if not pair:
        rh = remove_harmonics(method, h, fs, pulses, families, ppr, **run)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    ds = separation_metrics(r, n, h, fs, pulses, families, modes,
                            rpm_bins=spec["metric_rpm_bins"],
                            half_width=spec["mode_half_width"],
                            f_max=spec["max_frequency"], pulses_per_rev=ppr,
                            harmonic_residual=rh)
    # the bins where an order lies within a mode's half-power band: order and mode
    order, mode = crossing_lines(families, ds.rpm_lower.values, ds.rpm_upper.values,
                                 envelope_modes(bench, spec),
                                 np.column_stack([ds.band_lower.values, ds.band_upper.values]))
    dims = ("family", "band", "rpm")
    ds["crossing_order"] = (dims, order, {"units": "1", "long_name": "order of the family "
                                          "within the half-power band of a mode of the band"})
    ds["crossing_mode"] = (dims, mode, {"units": "Hz", "long_name": "frequency of the mode "
                                        "whose half-power band the order crosses"})
    ds["residual"] = ("time", r, {"units": sig.attrs["units"],
                                  "long_name": f"{method} residual of {sig.attrs['long_name']}"})
    ds = ds.assign_coords(time=sweep.time)
    ds.attrs.update(method=method, params=repr(dict(params)), families=" ".join(families),
                    signal=name)
    mode_bands = ds.band != "elsewhere"
    log.info("%s: %.2f s, peak %.0f MB (%.0f bytes per sample%s); worst-bin attenuation %s dB;"
             " worst mode-band level change %.2f dB",
             method, runtime, peak / 1e6, peak / x.size,
             ": the sweep and its harmonic part in one call" if pair else "", ", ".join(
                 f"{f} {float(v):.1f}" for f, v in zip(
                     ds.family.values, ds.leftover_db.min("rpm").values, strict=True)),
             float(np.abs(ds.change_db.sel(band=mode_bands)).max()))
    return ds


def removal_rows(datasets: Sequence[xr.Dataset]) -> list[dict[str, Any]]:
    """One row per method x record x signal x family x rpm bin x band.

    ``datasets``: :func:`compare_method` outputs (the sweep, several rpm bins) and
    :func:`record_separation` outputs (a test: one bin over the record, one per signal).

    Columns: ``method``, ``record`` (``sweep`` or ``<test>_<profile>``), ``signal``,
    ``family``, ``band``, ``rpm``, ``rpm_lower``, ``rpm_upper`` [rev/min] (empty for a
    test), ``band_lower``, ``band_upper`` [Hz], ``attenuation_db`` (of the family, against
    the harmonic part), ``leftover_db`` (the method on the harmonic part alone),
    ``distortion_db`` and ``change_db`` (the band, against the random-only record)
    [dB], ``crossing`` (1 where an order of the family passes through the band),
    ``crossing_order`` [HSS orders] and ``crossing_mode`` [Hz] (the order of the family
    within the half-power band ``f_n (1 +- zeta)`` of a bench mode of the band, and that
    mode; NaN where none, and on a test). ``leftover_db`` is empty (NaN) where a dataset
    has none.
    """
    rows = []
    for ds in datasets:
        test = "signal" in ds.dims
        signals = [str(v) for v in ds.signal.values] if test else [ds.attrs["signal"]]
        record = f"{ds.attrs['test']}_{ds.attrs['profile']}" if test else "sweep"
        for j, sig in enumerate(signals):
            one = ds.isel(signal=j).expand_dims("rpm") if test else ds
            n_bins = one.sizes["rpm"]
            nan = np.full((one.sizes["family"], n_bins), np.nan)
            att = one.attenuation_db.transpose("family", "rpm").values
            left = (one.leftover_db.transpose("family", "rpm").values
                    if "leftover_db" in one else nan)
            dist = one.distortion_db.transpose("band", "rpm").values
            change = one.change_db.transpose("band", "rpm").values
            cross = one.crossing.transpose("family", "band", "rpm").values
            nan3 = np.full(cross.shape, np.nan)
            c_order, c_mode = ((one[v].transpose("family", "band", "rpm").values
                                if v in one else nan3)
                               for v in ("crossing_order", "crossing_mode"))
            # the coordinates as numpy arrays once: an xarray index per row and column
            # cost 0.3 ms, most of the table's time
            bins = (None if test else
                    np.column_stack([one[c].values for c in ("rpm", "rpm_lower", "rpm_upper")]))
            band_lower, band_upper = one.band_lower.values, one.band_upper.values
            for k, fam in enumerate(one.family.values):
                for i in range(n_bins):
                    rpm = [""] * 3 if test else [float(v) for v in bins[i]]
                    for b, band in enumerate(one.band.values):
                        rows.append({
                            "method": ds.attrs["method"], "record": record, "signal": sig,
                            "family": str(fam), "band": str(band), "rpm": rpm[0],
                            "rpm_lower": rpm[1], "rpm_upper": rpm[2],
                            "band_lower": float(band_lower[b]),
                            "band_upper": float(band_upper[b]),
                            "attenuation_db": float(att[k, i]),
                            "leftover_db": float(left[k, i]),
                            "distortion_db": float(dist[b, i]),
                            "change_db": float(change[b, i]),
                            "crossing": int(cross[k, b, i]),
                            "crossing_order": float(c_order[k, b, i]),
                            "crossing_mode": float(c_mode[k, b, i]),
                        })
    return rows


def method_residuals(record: xr.Dataset | Sequence[xr.Dataset], names: Sequence[str],
                     method: str, params: Mapping[str, Any], families: Families,
                     keep_below: float, angle_record: xr.Dataset | None = None,
                     ) -> xr.Dataset | list[xr.Dataset]:
    """Measured-like signals of a record after one removal method (``removal_tests``).

    Parameters
    ----------
    record, names, keep_below
        As :func:`gbpipe.harmonics.split_residuals` (``keep_below`` times the lowest
        removed order, as for TSA, so every version sees the same low part). Several
        records: a record and its harmonic part (:func:`harmonic_record`), removed in
        one call (a :data:`gbpipe.harmonics.removal.MULTICHANNEL` method builds its
        regressors and factor once for both: half the regression's work in
        ``removal_tests``); one dataset per record, each as it would be alone.
    method : str
        A name of :data:`gbpipe.harmonics.removal.METHODS`.
    params : mapping
        Its keyword arguments (:func:`method_params`).
    families : mapping str -> orders
        The families removed [HSS orders].
    angle_record : xarray.Dataset, optional
        The record whose measured speeds give the regression's second angle
        (:func:`record_params`; default ``record``, the first one): the record itself
        when ``record`` is its harmonic part (:func:`harmonic_record`, no speeds).

    Returns
    -------
    xarray.Dataset or list of xarray.Dataset
        One variable per name (time); attributes ``method``, ``families``, ``params``.
        One per record when ``record`` is a sequence.
    """
    first = record if isinstance(record, xr.Dataset) else record[0]
    # the piece split_residuals works on, so that the twist has the samples of x
    run = record_params(params, longest_segment(first if angle_record is None
                                                else angle_record))

    def remove(x: np.ndarray, fs: float, pulses: np.ndarray, ppr: int) -> np.ndarray:
        return remove_harmonics(  # (x: split_residuals' own array, which it may reuse)
            method, x, fs, pulses, families, ppr, overwrite_x=True, **run)

    lowest, what = (min(float(o) for orders in families.values() for o in orders),
                    f"{method} removal of {', '.join(families)}")
    values = first.sizes["time"] * (1 if first is record else len(record))  # per channel
    groups = channel_groups(method, names, values)  # MULTICHANNEL ones share regressors
    progress = Progress(log, f"{what}: {len(names)} signals", len(groups))
    out: list[xr.Dataset] = []
    for k, group in enumerate(groups, 1):
        part = split_residuals(record, group, remove, lowest, keep_below, what)
        part = [part] if isinstance(part, xr.Dataset) else part
        out = [o.assign(p.data_vars) for o, p in zip(out, part, strict=True)] if out else part
        progress(k, ", ".join(group))
    for ds in out:
        ds.attrs.update(method=method, families=" ".join(families), params=repr(dict(params)))
    return out[0] if isinstance(record, xr.Dataset) else out


def harmonic_record(record: xr.Dataset, random_only: xr.Dataset,
                    names: Sequence[str]) -> xr.Dataset:
    """``record`` whose measured-like signals are replaced by their harmonic part
    (``record - random_only``): what :func:`method_residuals` runs on for ``leftover_db``."""
    out = record.copy()
    for name in names:
        x, n = measured_signal(record, name), measured_signal(random_only, name)
        if n.shape != x.shape:
            raise DataError("random-only test", f"{name} has {n.size} samples, the test "
                            f"{x.size}: simulate both from the same config")
        out[x.name] = x - n.values
    return out


def record_separation(residuals: xr.Dataset, harmonic: xr.Dataset, random_only: xr.Dataset,
                      bench: xr.Dataset, families: Families, spec: Mapping[str, Any],
                      harmonic_residuals: xr.Dataset | None = None) -> xr.Dataset:
    """The exact separation metric of each signal of :func:`method_residuals`.

    Parameters
    ----------
    residuals : xarray.Dataset
        :func:`method_residuals` of the test record (one variable per signal).
    harmonic, random_only : xarray.Dataset
        The record's harmonic part (:func:`harmonic_record`: the record's pulses and
        attributes) and the same simulation without the angle-locked excitation
        (:func:`gbpipe.simulate.random_only`).
    bench, families, spec
        As :func:`compare_method`; one rpm bin spans the whole record (a ramp test holds
        one or two speeds).
    harmonic_residuals : xarray.Dataset, optional
        :func:`method_residuals` of :func:`harmonic_record`: adds ``leftover_db``.

    Returns
    -------
    xarray.Dataset
        ``residuals`` with ``attenuation_db`` and ``leftover_db`` (signal, family),
        ``distortion_db`` and ``change_db`` (signal, band) [dB] and ``crossing`` (family,
        band) [1].
    """
    fs = float(harmonic.attrs["sample_rate"])
    pulses = np.asarray(harmonic.pulse_time.values, dtype=float)
    modes = watched_modes(bench, spec)
    names = [str(n) for n in residuals.data_vars]
    per_signal = []
    for name in names:
        n = np.asarray(measured_signal(random_only, name).values, dtype=float)
        h = np.asarray(measured_signal(harmonic, name).values, dtype=float)
        met = separation_metrics(residuals[name].values, n, h, fs, pulses, families,
                                 modes, rpm_bins=1, half_width=spec["mode_half_width"],
                                 f_max=spec["max_frequency"],
                                 pulses_per_rev=int(harmonic.attrs["pulses_per_rev"]),
                                 harmonic_residual=None if harmonic_residuals is None
                                 else harmonic_residuals[name].values)
        per_signal.append(met.isel(rpm=0, drop=True))
    first = per_signal[0]
    out = {v: (("signal", *first[v].dims), np.stack([m[v].values for m in per_signal]),
               first[v].attrs) for v in ("attenuation_db", "leftover_db", "distortion_db",
                                         "change_db") if v in first}
    out["crossing"] = first.crossing
    coords = {k: first.coords[k] for k in ("family", "band", "band_lower", "band_upper")}
    coords["signal"] = ("signal", names, {"units": "1", "long_name": "signal after removal"})
    met = xr.Dataset(out, coords=coords)
    return xr.merge([residuals, met], combine_attrs="override")

