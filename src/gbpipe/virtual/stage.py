"""The ``virtual`` stage: one bench record → the estimated torques (and speeds) of the
chain with their 95 % bands, the held-out sensors compared, and the load spectra of every
measured and estimated torque (docs/virtual.md).

What the workflow calls (:func:`virtual_record`): the chain built from the model sections
(the configured chain, or the fitted overlay merged by the rule), the record's motor
torques as known inputs, the chosen sensors as measurements; noise from the record's
``virtual.noise.window`` (maximum likelihood), then the steady-state smoother over the
whole record. Fit, coverage and the load spectra are computed on the steady part (the
filter's start and the smoother's end transients left out, ``steady`` in the output).

Hour-long records (issue 47): the output is written as the smoother makes it, block by
block (:func:`gbpipe.io.block_writer`), the held-out comparison accumulated over the same
blocks (:class:`gbpipe.virtual.holdout.HoldoutFit`); a second pass over the steady part,
forward, reads the estimates back from the file and the measured torques from the record
for the load spectra (:class:`gbpipe.loads.BlockSpectrum`: their level bins need each
signal's range, known after the first pass). What stays in memory for the whole record:
the measured channels the estimator reads and the time axis, and the load spectra's
turning points.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gbpipe import io
from gbpipe.errors import ConfigError, DataError
from gbpipe.loads import BlockSpectrum
from gbpipe.model import bench_chain
from gbpipe.progress import Progress
from gbpipe.virtual.holdout import HoldoutFit
from gbpipe.virtual.model import estimation_model, target_names
from gbpipe.virtual.noise import fit_noise
from gbpipe.virtual.output import LATE_HOLDOUT, LATE_SPECTRA, Layout, template
from gbpipe.virtual.smoother import BLOCK, Z95, Estimate, NoiseModel, smooth

__all__ = ["virtual_record", "table_rows", "TABLE_COLUMNS"]

log = logging.getLogger(__name__)

#: Columns of ``tables/virtual.csv`` (one row per record and held-out signal).
TABLE_COLUMNS = ["record", "signal", "unit", "fit_percent", "fit_percent_with_mean",
                 "rms_error", "coverage_95", "steady_samples", "noise_window_s"]


def _columns(record: xr.Dataset, names: list[str], field: str,
             part: slice = slice(None)) -> np.ndarray:
    """The record's signals ``names`` over the samples ``part``, as columns (float64)."""
    missing = [n for n in names if n not in record]
    if missing:
        raise ConfigError(field, f"the record has no signal {', '.join(missing)}; its "
                          f"signals: {', '.join(map(str, record.data_vars))}; name them as "
                          "the chain's sensors and motor inputs (measured.<record>.signals)")
    n = len(range(record.sizes["time"])[part])
    out = np.empty((n, len(names)))
    # one column at a time into one array: no second copy of the record's channels
    for i, name in enumerate(names):
        out[:, i] = record[name].isel(time=part).values
    return out


def virtual_record(settings: Mapping[str, Any], model_cfg: Mapping[str, Any],
                   record: xr.Dataset, name: str, out: str | os.PathLike, *,
                   signals: Mapping[str, str] | None = None,
                   provenance: Mapping[str, Any] | None = None) -> Path:
    """Virtual sensors of one bench record (module docstring), written to ``out``.

    Parameters
    ----------
    settings : mapping
        The validated ``virtual:`` section.
    model_cfg : mapping
        The model sections (``drivetrain:``, or the paper's ``gearbox:`` + ``bench:``),
        fitted values merged where ``virtual.model: fitted``.
    record : xarray.Dataset
        ``measured/{record}.nc`` (signals named as the chain's sensors and
        ``motor_torque_<motor>``) [SI]; best opened lazily (``io.read(path, lazy=True)``):
        the held-out and measured torques are read block by block.
    name : str
        Record name (errors).
    out : path-like
        ``virtual/{record}.nc`` (docs/architecture.md, "Data contract"), written
        atomically.
    signals : mapping, optional
        Record signal name → the chain's (``fit.signals``) where they differ.
    provenance : mapping, optional
        Keyword arguments of :func:`gbpipe.io.write` (``stage``, default ``"virtual"``,
        ``config``, ``wildcards``, ``sources``, ``title``).

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    gbpipe.errors.ConfigError
        A sensor, motor input or held-out signal the record lacks; an unknown element.
    gbpipe.errors.DataError
        Sensors that cannot observe the chain; a noise window with too few samples; a
        record shorter than the estimator's transients.
    """
    chain = bench_chain(model_cfg)
    record = record.rename({k: v for k, v in (signals or {}).items() if k in record})
    holdout = list(settings["holdout"])
    known = [*chain.speed_sensors, *chain.torque_sensors, *chain.angle_sensors]
    sensors = list(settings["sensors"]) or [s for s in known if s in record
                                            and s not in holdout]
    targets = target_names(chain, settings["torques"], settings["speeds"])
    targets += [h for h in holdout if h not in targets]
    t = np.asarray(record.time.values, dtype=float)   # no copy of a float64 axis
    dt = float(np.median(np.diff(t)))
    model = estimation_model(chain, sensors, targets, settings["loads"], dt,
                             offsets=settings["offsets"])
    w0, w1 = settings["noise"]["window"]
    # the window is one stretch of the record: a slice, read alone
    win = slice(*np.searchsorted(t, [t[0] + w0, t[0] + w1]))
    n_win = len(range(len(t))[win])
    if n_win < 20 * (len(model.states) + 1):
        raise DataError(name, f"the noise window [{w0}, {w1}] s holds {n_win} "
                        "samples, too few for the noise fit; widen virtual.noise.window")
    y = _columns(record, model.measured, "virtual.sensors")
    u = _columns(record, model.inputs, "virtual.sensors")
    # the noise levels (one number per sensor) are fitted with the held-out sensors read
    # too: a held-out measurement is compared within its own noise; the estimate never
    # reads a held-out signal
    every = estimation_model(chain, sensors + holdout, [], settings["loads"], dt,
                             offsets=settings["offsets"])
    nf = fit_noise(every, _columns(record, every.measured, "virtual.holdout", win), u[win])
    noise = NoiseModel(nf.noise.sensor_sd[:len(sensors)], nf.noise.input_sd,
                       nf.noise.load_rate, nf.noise.model_sd)
    est = smooth(model, noise, y, u, block=BLOCK)
    steady = np.flatnonzero(est.steady)
    if steady.size < 2:
        raise DataError(name, f"the record ({len(t)} samples) is shorter than the "
                        "estimator's start and end transients: no steady part to compare or "
                        "count; give a longer record")
    labels = model.targets + [model.states[i] for i in model.load_states]
    # a target's unit: its sensor's or state's; shaft torques and loads are N m
    units = [model.units.get(s, "N m") for s in labels]
    # every spectrum over the steady part (the estimates' start and end transients are no
    # load the shaft saw; the measured torques over the same samples, to compare)
    measured = [n for n in [*model.inputs, *[x for x in sensors if x in chain.torque_sensors],
                            *holdout]
                if n in record and (n.startswith("motor_torque_") or n in chain.torque_sensors)]
    measured = list(dict.fromkeys(measured))
    lay = Layout(labels, units, holdout, measured + [
        lab for j, lab in enumerate(labels) if units[j] == "N m" and lab not in measured
        and lab.startswith("torque_")], measured)
    attrs = {"noise_window_start_s": float(t[win][0] - t[0]),
             "noise_window_end_s": float(t[win][-1] - t[0]),
             "noise_source": (f"maximum likelihood on the innovations of samples "
                              f"{win.start}-{win.stop - 1}"
                              f" ({t[win][0] - t[0]:g}-{t[win][-1] - t[0]:g} s)"),
             "noise_converged": int(nf.converged), "noise_evaluations": nf.evaluations,
             "noise_scale": est.scale, "equivalent_frequency_hz":
                 float(settings["spectra"]["equivalent_frequency"]), "model": settings["model"]}
    ds = template(lay, model, est, nf, len(sensors), settings["loads"], t[:2] - t[0], dt,
                  settings["spectra"], attrs)
    # the steady part is one stretch (between the start and end transients)
    keep = (int(steady[0]), int(steady[-1]) + 1)
    late = LATE_SPECTRA + (LATE_HOLDOUT if holdout else [])
    kw = {"stage": "virtual", **(provenance or {})}
    with io.block_writer(ds, len(t), out, late=late, **kw) as f:
        ranges = _estimates(f, est, record, lay, t, keep, nf.noise.sensor_sd[len(sensors):],
                            name)
        # the channels the smoother read, and the smoother, are no longer needed: their
        # memory for the spectra's turning points
        del est, y, u, t
        _spectra(f, record, lay, keep, ranges, dt, settings["spectra"], name)
    log.info("%s: %s; targets %s", name, attrs["noise_source"], ", ".join(labels))
    return Path(out)


def _estimates(f: io.BlockFile, est: Estimate, record: xr.Dataset, lay: Layout, t: np.ndarray,
               keep: tuple[int, int], holdout_sd: np.ndarray, name: str) -> np.ndarray:
    """The smoother's pass: every variable on time written as its blocks come (the last
    first), the held-out comparison set; returns each spectra signal's smallest and
    largest value over the steady part (n_signals, 2)."""
    ih = [lay.labels.index(h) for h in lay.holdout]
    fit = HoldoutFit(Z95 * np.hypot(est.sd[ih], holdout_sd))
    ranges = np.tile([np.inf, -np.inf], (len(lay.signals), 1))
    # the smoother's blocks, and its first sample alone (Estimate.blocks)
    blocks = len(range(0, len(t) - 1, BLOCK)) + 1
    progress = Progress(log, f"{name}: smoother's pass, estimates written", blocks)
    for done, (a, z) in enumerate(est.blocks(), 1):
        b = a + len(z)
        f.write("time", a, t[a:b] - t[0])
        f.write("steady", a, est.steady[a:b].astype(np.int8))
        f.write("estimate", a, z)
        f.write("lower", a, z - Z95 * est.sd)
        f.write("upper", a, z + Z95 * est.sd)
        m = _columns(record, lay.holdout, "virtual.holdout", slice(a, b))
        if lay.holdout:
            f.write("holdout_measured", a, m)
        k0, k1 = max(a, keep[0]) - a, min(b, keep[1]) - a
        if k0 < k1:
            if lay.holdout:
                fit.add(m[k0:k1], z[k0:k1][:, ih])
            x = _signals(record, lay, z[k0:k1], slice(a + k0, a + k1))
            ranges[:, 0] = np.minimum(ranges[:, 0], x.min(axis=0))
            ranges[:, 1] = np.maximum(ranges[:, 1], x.max(axis=0))
        progress(done)
    if lay.holdout:
        for key, value in fit.result().items():
            f.set(f"holdout_{key}", value)
    return ranges


def _signals(record: xr.Dataset, lay: Layout, z: np.ndarray, part: slice) -> np.ndarray:
    """The spectra signals over ``part`` (n, n_signals): the measured ones from the
    record, the estimated ones from their columns of ``z`` (the estimates over ``part``)."""
    estimated = [lay.labels.index(x) for x in lay.signals if x not in lay.measured]
    return np.hstack([_columns(record, lay.measured, "virtual.sensors", part),
                      z[:, estimated]])


def _spectra(f: io.BlockFile, record: xr.Dataset, lay: Layout, keep: tuple[int, int],
             ranges: np.ndarray, dt: float, s: Mapping[str, Any], name: str) -> None:
    """The load spectra's pass, forward over the steady part: the estimates read back
    from ``f``, the measured torques from the record; the spectra set in ``f``."""
    spec = [BlockSpectrum(lo, hi, s["bins"], dt) for lo, hi in ranges]
    starts = range(keep[0], keep[1], BLOCK)
    progress = Progress(log, f"{name}: load spectra of {len(spec)} torques, turning points",
                        len(starts))
    for done, a in enumerate(starts, 1):
        b = min(a + BLOCK, keep[1])
        x = _signals(record, lay, f.read("estimate", a, b), slice(a, b))
        for k, sp in enumerate(spec):
            sp.add(x[:, k])
        progress(done)
    out = {k: [] for k in LATE_SPECTRA}
    for sp in spec:   # one signal's cycles at a time
        r = sp.result(list(s["sn_slopes"]), s["equivalent_frequency"])
        for key, value in zip(LATE_SPECTRA, (r.range_centre, r.cycle_count, r.level_centre,
                                             r.time_at_level, r.del_), strict=True):
            out[key].append(value)
    for key, values in out.items():
        f.set(key, np.array(values).reshape(len(spec), -1))


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

