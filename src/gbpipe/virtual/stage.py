"""The ``virtual`` stage: one bench record → the estimated torques (and speeds) of the
chain with their 95 % bands, the held-out sensors compared, and the load spectra of every
measured and estimated torque (docs/virtual.md).

What the workflow calls (:func:`virtual_record`): the chain built from the model sections
(the configured chain, or the fitted overlay merged by the rule), the record's motor
torques as known inputs, the chosen sensors as measurements; noise from the record's
``virtual.noise.window`` (maximum likelihood), then the steady-state smoother over the
whole record. Fit, coverage and the load spectra are computed on the steady part (the
filter's start and the smoother's end transients left out, ``steady`` in the output).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import ConfigError, DataError
from gbpipe.loads import damage_equivalent_load, load_duration, rainflow_cycles, range_histogram
from gbpipe.lti import fit_percent
from gbpipe.model import bench_chain
from gbpipe.virtual.model import estimation_model, target_names
from gbpipe.virtual.noise import fit_noise
from gbpipe.virtual.smoother import Z95, NoiseModel, smooth

__all__ = ["virtual_record", "table_rows", "TABLE_COLUMNS"]

#: Columns of ``tables/virtual.csv`` (one row per record and held-out signal).
TABLE_COLUMNS = ["record", "signal", "unit", "fit_percent", "fit_percent_with_mean",
                 "rms_error", "coverage_95", "steady_samples", "noise_window_s"]


def _var(dims: tuple[str, ...], values: Any, unit: str, name: str) -> tuple:
    return dims, values, {"units": unit, "long_name": name}


def _columns(record: xr.Dataset, names: list[str], field: str) -> np.ndarray:
    missing = [n for n in names if n not in record]
    if missing:
        raise ConfigError(field, f"the record has no signal {', '.join(missing)}; its "
                          f"signals: {', '.join(map(str, record.data_vars))}; name them as "
                          "the chain's sensors and motor inputs (measured.<record>.signals)")
    return np.column_stack([record[n].values.astype(float) for n in names])


def _spectra(signals: Mapping[str, np.ndarray], dt: float, slopes: list[float],
             f_eq: float, bins: int) -> dict[str, tuple]:
    """Rainflow range histogram, load-duration distribution and DEL of each torque."""
    hist, centre, ldd, level, dels = [], [], [], [], []
    for x in signals.values():
        cyc = rainflow_cycles(x)
        top = max(float(cyc.range.max()) if cyc.range.size else 0.0, 1e-12)
        edges = np.linspace(0.0, top, bins + 1)
        hist.append(range_histogram(cyc, edges))
        centre.append(0.5 * (edges[1:] + edges[:-1]))
        lo, hi = float(x.min()), float(x.max())
        ledges = np.linspace(lo, hi if hi > lo else lo + 1e-12, bins + 1)
        ldd.append(load_duration(x, dt, ledges))
        level.append(0.5 * (ledges[1:] + ledges[:-1]))
        dels.append(damage_equivalent_load(cyc, slopes, f_eq * len(x) * dt))
    sd, rd, ld = ("signal",), ("signal", "range_bin"), ("signal", "level_bin")
    return {
        "cycle_range": _var(rd, np.array(centre), "N m", "rainflow range (bin centre)"),
        "cycle_count": _var(rd, np.array(hist), "1", "rainflow cycles in the range bin "
                            "(half cycles count 1/2)"),
        "load_level": _var(ld, np.array(level), "N m", "torque level (bin centre)"),
        "time_at_level": _var(ld, np.array(ldd), "s", "time at level (load-duration "
                              "distribution)"),
        "del": _var(sd + ("sn_slope",), np.array(dels), "N m",
                    f"damage-equivalent load range at {f_eq:g} Hz equivalent cycles "
                    "(N_eq = f_eq T, T the steady part's duration)"),
    }


def virtual_record(settings: Mapping[str, Any], model_cfg: Mapping[str, Any],
                   record: xr.Dataset, name: str,
                   signals: Mapping[str, str] | None = None) -> xr.Dataset:
    """Virtual sensors of one bench record (module docstring).

    Parameters
    ----------
    settings : mapping
        The validated ``virtual:`` section.
    model_cfg : mapping
        The model sections (``drivetrain:``, or the paper's ``gearbox:`` + ``bench:``),
        fitted values merged where ``virtual.model: fitted``.
    record : xarray.Dataset
        ``measured/{record}.nc`` (signals named as the chain's sensors and
        ``motor_torque_<motor>``) [SI].
    name : str
        Record name (errors).
    signals : mapping, optional
        Record signal name → the chain's (``fit.signals``) where they differ.

    Returns
    -------
    xarray.Dataset
        ``virtual/{record}.nc`` (docs/architecture.md, "Data contract").

    Raises
    ------
    gbpipe.errors.ConfigError
        A sensor, motor input or held-out signal the record lacks; an unknown element.
    gbpipe.errors.DataError
        Sensors that cannot observe the chain; a noise window with too few samples.
    """
    chain = bench_chain(model_cfg)
    record = record.rename({k: v for k, v in (signals or {}).items() if k in record})
    holdout = list(settings["holdout"])
    known = [*chain.speed_sensors, *chain.torque_sensors, *chain.angle_sensors]
    sensors = list(settings["sensors"]) or [s for s in known if s in record
                                            and s not in holdout]
    targets = target_names(chain, settings["torques"], settings["speeds"])
    targets += [h for h in holdout if h not in targets]
    t = record.time.values.astype(float)
    dt = float(np.median(np.diff(t)))
    model = estimation_model(chain, sensors, targets, settings["loads"], dt,
                             offsets=settings["offsets"])
    y = _columns(record, model.measured, "virtual.sensors")
    u = _columns(record, model.inputs, "virtual.sensors")
    w0, w1 = settings["noise"]["window"]
    win = (t >= t[0] + w0) & (t < t[0] + w1)
    if win.sum() < 20 * (len(model.states) + 1):
        raise DataError(name, f"the noise window [{w0}, {w1}] s holds {int(win.sum())} "
                        "samples, too few for the noise fit; widen virtual.noise.window")
    # the noise levels (one number per sensor) are fitted with the held-out sensors read
    # too: a held-out measurement is compared within its own noise; the estimate never
    # reads a held-out signal
    every = estimation_model(chain, sensors + holdout, [], settings["loads"], dt,
                             offsets=settings["offsets"])
    nf = fit_noise(every, _columns(record, every.measured, "virtual.holdout")[win], u[win])
    noise = NoiseModel(nf.noise.sensor_sd[:len(sensors)], nf.noise.input_sd,
                       nf.noise.load_rate, nf.noise.model_sd)
    holdout_sd = nf.noise.sensor_sd[len(sensors):]
    est = smooth(model, noise, y, u)
    del y, u   # the record's channels, no longer needed: their memory for the output's
    labels = model.targets + [model.states[i] for i in model.load_states]
    # a target's unit: its sensor's or state's; shaft torques and loads are N m
    units = [model.units.get(s, "N m") for s in labels]
    lo, hi = est.z - Z95 * est.sd, est.z + Z95 * est.sd
    td, mixed = ("time", "target"), "mixed (see target_units)"
    v = {
        "estimate": _var(td, est.z, mixed, "smoothed estimate"),
        "lower": _var(td, lo, mixed, "lower end of the 95 % band"),
        "upper": _var(td, hi, mixed, "upper end of the 95 % band"),
        "estimate_sd": _var(("target",), est.sd, mixed, "standard deviation of the estimate "
                            "(steady state, offsets' uncertainty included)"),
        "steady": _var(("time",), est.steady.astype(np.int8), "1",
                       "1 where every estimate's variance is within 5 % of its steady one "
                       "(outside the start and end transients)"),
        "offset_value": _var(("offset",), est.offsets, "N m", "estimated constant offset"),
        "offset_sd": _var(("offset",), est.offsets_sd, "N m", "its standard deviation"),
        "sensor_noise_sd": _var(("sensor",), noise.sensor_sd, "mixed (see sensor_units)",
                                "white-noise standard deviation (maximum likelihood)"),
        "input_noise_sd": _var(("input",), nf.noise.input_sd, "N m",
                               "motor-torque noise standard deviation (maximum likelihood)"),
        "load_step_sd": _var(("load",), nf.noise.load_rate * np.sqrt(dt), "N m",
                             "random-walk step of the unknown load per sample (maximum "
                             "likelihood)"),
        "model_noise_sd": _var((), nf.noise.model_sd, "N m", "white torque on every "
                               "coordinate: the model's error (maximum likelihood)"),
    }
    # the held-out sensors against their estimates, on the steady part (the record holds
    # them: the noise fit above read them)
    rows, steady = [], np.flatnonzero(est.steady)
    if steady.size < 2:
        raise DataError(name, f"the record ({len(t)} samples) is shorter than the "
                        "estimator's start and end transients: no steady part to compare or "
                        "count; give a longer record")
    # the steady part is one stretch (between the start and end transients): a slice,
    # whose selections are views, not copies of the record's length
    keep = slice(int(steady[0]), int(steady[-1]) + 1)
    measured_h = _columns(record, holdout, "virtual.holdout") if holdout else None
    for i, h in enumerate(holdout):
        j = labels.index(h)
        m, z = measured_h[keep, i], est.z[keep, j]
        # the band of the measurement: the estimate's and the sensor's own noise
        half = Z95 * np.hypot(est.sd[j], holdout_sd[i])
        rows.append({"fit_percent": float(fit_percent(m - m.mean(), z - z.mean())[0]),
                     "fit_percent_with_mean": float(fit_percent(m, z)[0]),
                     "rms_error": float(np.sqrt(np.mean((m - z) ** 2))),
                     "coverage_95": float(np.mean(np.abs(m - z) <= half))})
    if holdout:
        hd = ("holdout",)
        v["holdout_measured"] = _var(("time", "holdout"), measured_h,
                                     "mixed (see holdout_units)", "held-out measurement")
        for key, unit, text in (("fit_percent", "percent", "fit, means removed (steady part)"),
                                ("fit_percent_with_mean", "percent", "fit with the means"),
                                ("rms_error", "mixed (see holdout_units)", "RMS error"),
                                ("coverage_95", "1", "share of held-out samples in the "
                                 "band widened by the sensor's noise")):
            v[f"holdout_{key}"] = _var(hd, np.array([r[key] for r in rows]), unit, text)
        v["holdout_noise_sd"] = _var(hd, holdout_sd, "mixed (see holdout_units)",
                                     "the held-out sensor's white noise (maximum likelihood)")
    s = settings["spectra"]
    # every spectrum over the steady part (the estimates' start and end transients are no
    # load the shaft saw; the measured torques over the same samples, to compare)
    torques = {n: record[n].values[keep].astype(float) for n in
               [*model.inputs, *[x for x in sensors if x in chain.torque_sensors], *holdout]
               if n in record and (n.startswith("motor_torque_") or n in chain.torque_sensors)}
    measured_names = list(torques)
    torques.update({lab: est.z[keep, j] for j, lab in enumerate(labels)
                    if units[j] == "N m" and lab not in torques and lab.startswith("torque_")})
    spec = _spectra(torques, dt, list(s["sn_slopes"]), s["equivalent_frequency"],
                    s["bins"])
    spec["signal_source"] = _var(("signal",), np.array(
        ["measured" if n in measured_names else "estimated" for n in torques]), "1",
        "measured or estimated")
    v.update(spec)
    c = {
        "time": ("time", t - t[0], {"units": "s", "long_name": "time from record start"}),
        "target": _var(("target",), np.array(labels), "1", "estimated signal"),
        "target_units": _var(("target",), np.array(units), "1", "unit of each target"),
        "offset": _var(("offset",), np.array(model.offsets, dtype=str), "1",
                       "offset (offset_<sensor> or offset_motor_torque_<motor>)"),
        "sensor": _var(("sensor",), np.array(model.measured), "1", "measured sensor"),
        "sensor_units": _var(("sensor",), np.array([model.units[m] for m in model.measured]),
                             "1", "unit of each sensor"),
        "input": _var(("input",), np.array(model.inputs), "1", "motor torque (known input)"),
        "load": _var(("load",), np.array(list(settings["loads"]), dtype=str), "1",
                     "disk of an unknown load"),
        "signal": _var(("signal",), np.array(list(torques)), "1", "torque of the spectra"),
        "sn_slope": _var(("sn_slope",), np.array(s["sn_slopes"], dtype=float), "1",
                         "S-N curve slope m"),
    }
    if holdout:
        c["holdout"] = _var(("holdout",), np.array(holdout), "1", "held-out sensor")
        c["holdout_units"] = _var(("holdout",), np.array([units[labels.index(h)]
                                                          for h in holdout]), "1", "unit")
    attrs = {"noise_window_start_s": float(t[win][0] - t[0]),
             "noise_window_end_s": float(t[win][-1] - t[0]),
             "noise_source": (f"maximum likelihood on the innovations of samples "
                              f"{int(np.argmax(win))}-{int(np.argmax(win)) + int(win.sum()) - 1}"
                              f" ({t[win][0] - t[0]:g}-{t[win][-1] - t[0]:g} s)"),
             "noise_converged": int(nf.converged), "noise_evaluations": nf.evaluations,
             "noise_scale": est.scale, "equivalent_frequency_hz":
                 float(s["equivalent_frequency"]), "model": settings["model"]}
    return xr.Dataset(v, coords=c, attrs=attrs)


def table_rows(ds: xr.Dataset, record: str) -> list[dict]:
    """``tables/virtual.csv`` rows (:data:`TABLE_COLUMNS`) of a ``virtual`` output, one
    per held-out signal."""
    if "holdout" not in ds.dims:
        return []
    window = f"{ds.attrs['noise_window_start_s']:g}-{ds.attrs['noise_window_end_s']:g}"
    return [{"record": record, "signal": str(h), "unit": str(ds.holdout_units.values[i]),
             **{k: float(ds[f"holdout_{k}"].values[i]) for k in
                ("fit_percent", "fit_percent_with_mean", "rms_error", "coverage_95")},
             "steady_samples": int(ds.steady.values.sum()), "noise_window_s": window}
            for i, h in enumerate(ds.holdout.values)]

