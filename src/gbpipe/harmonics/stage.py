"""The harmonic-removal stage: what the workflow calls.

* :func:`sweep_waterfalls` -- rule ``spectra``: waterfalls of the raw sweep;
* :func:`tsa_variant` -- rule ``tsa``: one TSA variant on the sweep (residual, its
  waterfalls, removal metrics, and the plain cascade beside a joint removal);
* :func:`record_residuals` -- rule ``removal_tests``: measured-like signals of a record
  after removal of the ``tsa.tests`` families, for identification (any removal method:
  :func:`split_residuals`);
* :func:`remove`, :func:`waterfalls`, :func:`variant_metrics` -- their building blocks.

Inputs and outputs follow the data contract of docs/architecture.md ("Data contract");
the configuration is read without fallbacks (defaults are applied when it is loaded).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from fractions import Fraction
from typing import Any

import numpy as np
import xarray as xr
from scipy import signal

from gbpipe.errors import DataError
from gbpipe.harmonics.families import (
    cycle_orders,
    excitation_families,
    removed_families,
    structural_modes,
)
from gbpipe.harmonics.joint import residual_joint
from gbpipe.harmonics.metrics import removal_metrics
from gbpipe.harmonics.pieces import block_margin, by_pieces
from gbpipe.harmonics.spectra import order_spectrum_vs_rpm, power_spectrum_vs_rpm
from gbpipe.harmonics.tsa import residual
from gbpipe.io import longest_segment, mean_shaft_frequency, measured_signal
from gbpipe.progress import Progress

__all__ = ["waterfalls", "remove", "variant_metrics", "sweep_waterfalls", "tsa_variant",
           "split_residuals", "record_residuals", "watched_modes", "envelope_modes",
           "MODE_MIN_FREQUENCY"]

log = logging.getLogger(__name__)

#: Lowest structural mode watched by the removal metrics [Hz]: below it the bands would
#: hold the rigid-body and control dynamics, not a resonance.
MODE_MIN_FREQUENCY = 10.0


def watched_modes(bench: xr.Dataset, spec: Mapping[str, Any]) -> np.ndarray:
    """The bench modes a removal must leave alone [Hz]: the closed-loop modes of the model
    stage's ``bench.nc`` between :data:`MODE_MIN_FREQUENCY` and
    ``spec["mode_max_frequency"]``, pairs closer than ``spec["mode_half_width"]`` merged
    (:func:`gbpipe.harmonics.structural_modes`)."""
    return structural_modes(bench.closed_mode_frequency.values, MODE_MIN_FREQUENCY,
                            spec["mode_max_frequency"], spec["mode_half_width"])


def envelope_modes(bench: xr.Dataset, spec: Mapping[str, Any]) -> np.ndarray:
    """The bench modes whose swept response the regression's modal envelope carries:
    every closed-loop mode of ``bench.nc`` between :data:`MODE_MIN_FREQUENCY` and
    ``spec["mode_max_frequency"]``, each pole of a close pair on its own (the regression
    needs the resonances, not the watched bands).

    Returns
    -------
    numpy.ndarray, shape (modes, 2)
        Frequency [Hz] and damping ratio [-] of each mode.
    """
    f = bench.closed_mode_frequency.values
    z = bench.closed_mode_damping.values
    keep = (f > MODE_MIN_FREQUENCY) & (f < spec["mode_max_frequency"])
    return np.column_stack([f[keep], z[keep]])


def waterfalls(x: np.ndarray, fs: float, pulse_times: np.ndarray, spec: Mapping[str, Any],
               *, pulses_per_rev: int = 1, units: str = "N m",
               long_name: str = "torque") -> xr.Dataset:
    """Power spectrum vs rpm and order spectrum vs rpm of one signal.

    Parameters
    ----------
    x, fs : numpy.ndarray, float
        Signal in ``units``; its sample rate [Hz].
    pulse_times : numpy.ndarray
        HSS tachometer pulse times [s].
    spec : mapping
        ``cfg["spectra"]``.
    pulses_per_rev : int
        Tachometer pulses per HSS revolution.
    units, long_name : str
        Unit and name of ``x``.

    Returns
    -------
    xarray.Dataset
        ``power`` (rpm, frequency) and ``order_power`` (order_rpm, order) with their
        averaging counts; the order spectrum has its own rpm bins (``order_rpm``) because
        its frames are whole revolutions.
    """
    ps = power_spectrum_vs_rpm(x, fs, pulse_times=pulse_times, resolution=spec["resolution"],
                               window=spec["window"], overlap=spec["overlap"],
                               rpm_bins=spec["rpm_bins"], max_frequency=spec["max_frequency"],
                               pulses_per_rev=pulses_per_rev, units=units, long_name=long_name)
    log.info("%s: power spectrum vs rpm done; the order spectrum next", long_name)
    os_ = order_spectrum_vs_rpm(x, fs, pulse_times, resolution=spec["order_resolution"],
                                max_order=spec["max_order"], window=spec["window"],
                                overlap=spec["overlap"], rpm_bins=spec["rpm_bins"],
                                pulses_per_rev=pulses_per_rev, units=units, long_name=long_name)
    os_ = os_.rename({"rpm": "order_rpm", "rpm_lower": "order_rpm_lower",
                      "rpm_upper": "order_rpm_upper", "power": "order_power",
                      "n_averages": "order_n_averages"})
    for v in ("order_rpm", "order_rpm_lower", "order_rpm_upper"):
        os_[v].attrs["long_name"] = os_[v].attrs["long_name"] + " (order spectrum)"
    return xr.merge([ps, os_])


def remove(x: np.ndarray, fs: float, pulse_times: np.ndarray, cycles: Sequence[Fraction],
           tsa_cfg: Mapping[str, Any], *, pulses_per_rev: int = 1,
           mode: str = "joint") -> np.ndarray:
    """TSA residual of ``x`` with one or several cycle families removed.

    Parameters
    ----------
    x, fs, pulse_times, pulses_per_rev
        As in :func:`gbpipe.harmonics.residual`.
    cycles, tsa_cfg : sequence of Fraction, mapping
        Cycle orders [HSS orders] (:func:`gbpipe.harmonics.cycle_orders`); ``n_cycles``,
        ``unbiased`` and ``averaging`` (one variant's, or ``cfg["tsa"]``).
    mode : {"joint", "cascade"}
        For several cycles (:func:`gbpipe.harmonics.residual_joint`).
    """
    n = int(tsa_cfg["n_cycles"])
    opts = {"unbiased": bool(tsa_cfg["unbiased"]), "averaging": tsa_cfg["averaging"]}
    if len(cycles) == 1:
        return residual(x, fs, pulse_times, cycles[0], n, pulses_per_rev, **opts)
    return residual_joint(x, fs, pulse_times, list(cycles), n, pulses_per_rev, mode=mode,
                          **opts)


def variant_metrics(before: np.ndarray, after: np.ndarray, fs: float,
                    pulse_times: np.ndarray, families: Mapping[str, Sequence[Fraction]],
                    modes: Sequence[float], spec: Mapping[str, Any], *,
                    pulses_per_rev: int = 1) -> xr.Dataset:
    """Attenuation per removed family and band change per mode, overall and per rpm bin.

    :func:`gbpipe.harmonics.removal_metrics` with the ``cfg["spectra"]`` bins and band
    width; the rpm dimension is renamed ``metric_rpm`` so the metrics can sit beside
    spectra.
    """
    fam = {k: [float(o) for o in v] for k, v in families.items()}
    ds = removal_metrics(before, after, fs, pulse_times, fam, list(modes),
                         rpm_bins=spec["metric_rpm_bins"], half_width=spec["mode_half_width"],
                         pulses_per_rev=pulses_per_rev)
    ren = {v: f"metric_{v}" for v in ("rpm", "rpm_lower", "rpm_upper") if v in ds.variables}
    return ds.rename(ren)


@contextmanager
def _on_record(record: xr.Dataset, signals: str, step: str) -> Iterator[None]:
    """Re-raise a ``ValueError`` of ``step`` on a measured record as a
    :class:`gbpipe.errors.DataError` naming the record, the ``signals`` and the fix.

    On a bench record these fail from the data (a tacho mapped wrong gives too few pulses
    or a wrong speed), so the message gives what the pulses say of the shaft.
    """
    try:
        yield
    except ValueError as exc:
        if record.attrs.get("record_kind") != "measured":
            raise
        pulses = record["pulse_time"].values if "pulse_time" in record else np.empty(0)
        ppr = int(record.attrs.get("pulses_per_rev", 1))
        span = float(pulses[-1] - pulses[0]) if pulses.size > 1 else 0.0
        said = (f"{pulses.size} pulses over {span:.6g} s at {ppr} per rev: "
                f"{(pulses.size - 1) / ppr / span * 60.0:.6g} rpm mean" if span > 0
                else f"{pulses.size} pulse(s)")
        raise DataError(f"record '{record.attrs.get('record', '?')}': signal(s) {signals}",
                        f"{step} failed: {exc}. The tacho gives {said}; fix: check the "
                        f"record's tacho mapping (quantity: tacho with pulses_per_rev, "
                        f"tacho: analog/count/angle, scale:, threshold:) against the "
                        f"shaft speed, and that the record spans the revolutions "
                        f"{step} needs") from exc


def sweep_waterfalls(sweep: xr.Dataset, spec: Mapping[str, Any]) -> xr.Dataset:
    """Waterfalls of the sweep signal ``spec["signal"]`` (the ``spectra`` stage), or of a
    bench record's (its longest gap-free piece: :func:`gbpipe.io.longest_segment`)."""
    with _on_record(sweep, spec["signal"], "spectra"):
        return _sweep_waterfalls(longest_segment(sweep), spec)


def _sweep_waterfalls(sweep: xr.Dataset, spec: Mapping[str, Any]) -> xr.Dataset:
    x = sweep[spec["signal"]]
    return waterfalls(x.values.astype(float), float(sweep.attrs["sample_rate"]),
                      sweep.pulse_time.values, spec,
                      pulses_per_rev=int(sweep.attrs["pulses_per_rev"]),
                      units=x.attrs["units"], long_name=x.attrs["long_name"])


def tsa_variant(sweep: xr.Dataset, bench: xr.Dataset, variant: str,
                tsa_cfg: Mapping[str, Any], spec: Mapping[str, Any],
                stages: Sequence[Mapping[str, Any]],
                excitation: Mapping[str, Any],
                noise: Mapping[str, Any] | None = None) -> xr.Dataset:
    """One TSA variant on the sweep: the ``tsa`` stage.

    Parameters
    ----------
    sweep : xarray.Dataset
        The sweep record (``spec["signal"]``, ``pulse_time``, attributes ``sample_rate``
        and ``pulses_per_rev``).
    bench : xarray.Dataset
        The bench model output (``closed_mode_frequency`` [Hz]): the modes to watch.
    variant : str
        Variant name (written as an attribute).
    tsa_cfg : mapping
        The variant: ``cycles`` (names), ``n_cycles``, ``unbiased``, ``averaging``.
    spec : mapping
        ``cfg["spectra"]``.
    stages, excitation
        ``cfg["gearbox"]["stages"]`` and ``cfg["excitation"]``.
    noise : mapping, optional
        The sweep's noise section (``cfg["sweep"]["noise"]``): its pulsating torque is the
        ``motor`` family of the metrics.

    Returns
    -------
    xarray.Dataset
        The residual (time), its waterfalls (:func:`waterfalls`), the removal metrics
        (:func:`variant_metrics`) and, for several cycles, ``cascade_attenuation`` and
        ``cascade_attenuation_band`` of the plain cascade.
    """
    fs, pulses = float(sweep.attrs["sample_rate"]), sweep.pulse_time.values
    ppr = int(sweep.attrs["pulses_per_rev"])
    sig = sweep[spec["signal"]]
    x = sig.values.astype(float)
    cycles = cycle_orders(stages, tsa_cfg["cycles"])
    families = removed_families(
        excitation_families({"gearbox": {"stages": stages}, "excitation": excitation,
                             **({"noise": noise} if noise else {})}), cycles)
    modes = watched_modes(bench, spec)
    log.info("variant %s: cycles %s (orders %s); removed families %s", variant,
             tsa_cfg["cycles"], [f"{float(c):.4f}" for c in cycles], list(families))
    r = remove(x, fs, pulses, cycles, tsa_cfg, pulses_per_rev=ppr)
    ds = waterfalls(r, fs, pulses, spec, pulses_per_rev=ppr, units=sig.attrs["units"],
                    long_name=f"TSA residual of {sig.attrs['long_name']}")
    met = variant_metrics(x, r, fs, pulses, families, modes, spec, pulses_per_rev=ppr)
    ds = xr.merge([ds, met], compat="override")
    ds["residual"] = ("time", r, {"units": sig.attrs["units"],
                                  "long_name": f"TSA residual of {sig.attrs['long_name']}"})
    ds = ds.assign_coords(time=sweep.time)
    if len(cycles) > 1:
        # the plain cascade beside the joint removal: its own figure of merit
        rc = remove(x, fs, pulses, cycles, tsa_cfg, pulses_per_rev=ppr, mode="cascade")
        mc = variant_metrics(x, rc, fs, pulses, families, modes, spec, pulses_per_rev=ppr)
        for v in ("attenuation", "attenuation_band"):
            ds[f"cascade_{v}"] = mc[v].assign_attrs(
                long_name=mc[v].attrs["long_name"] + " (plain cascade)")
    ds.attrs.update(variant=variant, cycles=" ".join(tsa_cfg["cycles"]),
                    averaging=tsa_cfg["averaging"],
                    cycle_orders=" ".join(f"{c.numerator}/{c.denominator}" for c in cycles))
    for fam in ds.family.values:
        log.info("%s: attenuation %.1f dB (band %.1f dB)", fam,
                 float(ds.attenuation.sel(family=fam)),
                 float(ds.attenuation_band.sel(family=fam)))
    for m, f in zip(ds.mode.values, ds.mode_frequency.values, strict=True):
        log.info("mode %.1f Hz: band change %.2f dB (all bins %.2f dB)", f,
                 float(ds.mode_change.sel(mode=m)), float(ds.mode_change_all.sel(mode=m)))
    return ds


def split_residuals(record: xr.Dataset | Sequence[xr.Dataset], names: Sequence[str],
                    remove_fn: Callable[[np.ndarray, float, np.ndarray, int], np.ndarray],
                    lowest_order: float | None, keep_below: float,
                    what: str) -> xr.Dataset | list[xr.Dataset]:
    """Measured-like signals of a record after a harmonic removal, above a low split.

    Parameters
    ----------
    record : xarray.Dataset or sequence of xarray.Dataset
        A test record (``<name>_measured``) or a measured record (``<name>``;
        :func:`gbpipe.io.measured_signal`), with ``pulse_time`` of the GB1 HSS tacho and
        attributes ``sample_rate``, ``pulses_per_rev``; its longest gap-free piece is used.
        Or several records on the first one's time base and pulses (a record and its
        harmonic part, :func:`gbpipe.harmonics.harmonic_record`): the channels of all of
        them go to one ``remove_fn`` call, so that a method shares its work on the angle
        among them; each channel's result is the one it would have alone.
    names : sequence of str
        Signal names (without ``_measured``).
    remove_fn : callable
        ``remove_fn(x, fs, pulse_times, pulses_per_rev) -> residual``, ``x`` and the
        residual of shape ``(n, len(names))``: the signals' channels at once (several
        records: ``(records, n, len(names))``). ``x`` is this function's own array: the
        residual may be returned in it.
    lowest_order : float or None
        Lowest removed order [HSS orders]; None: nothing is removed.
    keep_below : float
        The removal acts only on the part of each signal above ``keep_below`` times
        ``lowest_order`` at the record's mean HSS speed (split by a zero-phase Butterworth
        low-pass; the low part is added back unchanged; 0 disables the split). Why: a TSA
        block's mean cycle also averages whatever else is in the block; for a step test
        that is the bench's slow step response, whose trend inside a 10-cycle block
        becomes a sawtooth at the cycle rate in the mean cycle, and whose block means
        form a staircase -- subtracting both would inject broadband errors far larger than
        the harmonics. Every harmonic lies at or above the lowest order, so the split
        loses none of them.
    what : str
        What was removed (long names).

    Returns
    -------
    xarray.Dataset or list of xarray.Dataset
        One variable per name (time) in the unit of the signal; attributes ``test``,
        ``profile``, ``sample_rate``. One per record when ``record`` is a sequence.
    """
    several = not isinstance(record, xr.Dataset)
    records = [longest_segment(r) for r in (record if several else [record])]
    record = records[0]
    if any(r.sizes["time"] != record.sizes["time"] for r in records[1:]):
        raise DataError(f"records {[str(r.attrs.get('test', '?')) for r in records]}",
                        f"have {[r.sizes['time'] for r in records]} samples: records removed "
                        "together share one time base and pulse train (harmonic_record)")
    fs = float(record.attrs["sample_rate"])
    pulses = np.asarray(record["pulse_time"].values, dtype=float)
    ppr = int(record.attrs["pulses_per_rev"])
    sos = None
    if lowest_order is not None and keep_below > 0:
        f_low = keep_below * lowest_order * mean_shaft_frequency(record)
        sos = signal.butter(6, f_low, fs=fs, output="sos")
    signals = [[measured_signal(r, name) for name in names] for r in records]
    # every record's channels in one array, filled channel by channel (not via a list)
    stacked = np.empty((len(records), record.sizes["time"], len(names)))
    for x, sig in zip(stacked, signals, strict=True):
        for j, m in enumerate(sig):
            x[:, j] = m.values
    if lowest_order is not None:
        for k, j in np.ndindex(len(records), len(names) if sos is not None else 0):
            stacked[k, :, j] -= signal.sosfiltfilt(sos, stacked[k, :, j])  # the high part
        # the channels in one call: a method may share its work on the angle among them.
        # The array is our own (the residual may replace it) and the low part is filtered
        # again, not kept: an hour's channels are held once, not three times (3.45 GB)
        stacked = np.asarray(remove_fn(stacked if several else stacked[0], fs, pulses, ppr,
                                       )).reshape(stacked.shape)
        for k, j in np.ndindex(len(records), len(names) if sos is not None else 0):
            stacked[k, :, j] += signal.sosfiltfilt(sos, np.asarray(signals[k][j].values, float))
    out = []
    for r, sig, x in zip(records, signals, stacked, strict=True):
        ds = xr.Dataset(coords={"time": ("time", r.time.values,
                                         {"units": "s", "long_name": "time from record start"})})
        for j, (name, measured) in enumerate(zip(names, sig, strict=True)):
            ds[name] = ("time", x[:, j], {"units": measured.attrs.get("units", "1"),
                                          "long_name": f"{name}, measured-like after {what}"})
        ds.attrs.update(test=str(r.attrs.get("test", "")),
                        profile=str(r.attrs.get("profile", "")), sample_rate=fs)
        out.append(ds)
    return out if several else out[0]


def record_residuals(record: xr.Dataset, names: Sequence[str],
                     stages: Sequence[Mapping[str, Any]], tsa_cfg: Mapping[str, Any],
                     keep_below: float) -> xr.Dataset:
    """Measured-like signals of a test record after joint TSA removal (``removal_tests``).

    Parameters
    ----------
    record, names, keep_below
        As :func:`split_residuals` (``keep_below`` times the lowest removed cycle).
    stages, tsa_cfg : sequence of mapping, mapping
        Gearbox stages (the exact cycle orders); ``cfg["tsa"]`` (``tests``: cycle names,
        ``n_cycles``, ``unbiased``).

    Returns
    -------
    xarray.Dataset
        :func:`split_residuals`, with attributes ``removed_cycles`` and ``n_cycles``.
    """
    cycles = cycle_orders(stages, tsa_cfg["tests"])
    n_cycles, unbiased = int(tsa_cfg["n_cycles"]), bool(tsa_cfg["unbiased"])

    def tsa(x: np.ndarray, fs: float, pulses: np.ndarray, ppr: int) -> np.ndarray:
        def joint(piece: np.ndarray, p: np.ndarray, t0: float) -> np.ndarray:
            return residual_joint(piece, fs, p, cycles, n_cycles, ppr, unbiased=unbiased,
                                  outside="keep", t0=t0)
        margin = block_margin(pulses, ppr, fs, cycles, n_cycles)  # x: one signal
        return by_pieces(x[:, 0], fs, pulses, margin, joint)[:, None]

    lowest = min(float(c) for c in cycles) if cycles else None
    what = f"TSA removal of {', '.join(tsa_cfg['tests'])}"
    progress = Progress(log, f"TSA of {len(names)} signals", len(names))
    with _on_record(record, ", ".join(names), "TSA"):  # one at a time: a long record's memory
        ds = split_residuals(record, names[:1], tsa, lowest, keep_below, what)
        for k, name in enumerate(names[1:], 2):
            ds[name] = split_residuals(record, [name], tsa, lowest, keep_below, what)[name]
            progress(k, name)
    ds.attrs.update(removed_cycles=",".join(tsa_cfg["tests"]), n_cycles=n_cycles)
    return ds
