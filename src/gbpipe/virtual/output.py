"""The ``virtual`` stage's output, ``virtual/{record}.nc`` (docs/architecture.md, "Data
contract"), as the template :func:`gbpipe.io.block_writer` fills: every variable with its
unit and long name, those on time two samples long, those known only once the record has
been through (the held-out comparison, the load spectra) as placeholders (:data:`LATE`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.virtual.model import EstimationModel
from gbpipe.virtual.noise import NoiseFit
from gbpipe.virtual.smoother import Estimate

__all__ = ["Layout", "template", "LATE_HOLDOUT", "LATE_SPECTRA", "MIXED"]

MIXED = "mixed (see target_units)"
#: Variables of the held-out comparison, set once every block has been seen.
LATE_HOLDOUT = ["holdout_fit_percent", "holdout_fit_percent_with_mean", "holdout_rms_error",
                "holdout_coverage_95"]
#: Variables of the load spectra, set after their pass over the steady part.
LATE_SPECTRA = ["cycle_range", "cycle_count", "load_level", "time_at_level", "del"]


@dataclass
class Layout:
    """What the output holds (names and units), fixed before the record is smoothed.

    Attributes
    ----------
    labels, units : list of str
        The estimated signals (``model.targets`` then the loads) and their units.
    holdout : list of str
        The held-out sensors.
    signals : list of str
        The torques of the load spectra, the measured ones first.
    measured : list of str
        Those of ``signals`` read from the record.
    """

    labels: list[str]
    units: list[str]
    holdout: list[str]
    signals: list[str]
    measured: list[str]


def _var(dims: tuple[str, ...], values: Any, unit: str, name: str) -> tuple:
    return dims, values, {"units": unit, "long_name": name}


def template(lay: Layout, model: EstimationModel, est: Estimate, nf: NoiseFit,
             sensors: int, loads: Sequence[str], time: np.ndarray, dt: float,
             spectra: Mapping[str, Any], attrs: Mapping[str, Any]) -> xr.Dataset:
    """The output with its first two samples' ``time`` and placeholders on it.

    Parameters
    ----------
    lay : Layout
    model : EstimationModel
        The estimation model (without the held-out sensors).
    est : Estimate
        The smoother's bands, offsets and steady part.
    nf : NoiseFit
        The noise fit (the held-out sensors' levels after the ``sensors`` read ones).
    sensors : int
        Sensors read by the estimate [-].
    loads : sequence of str
        Disks of an unknown load.
    time : ndarray (2,)
        The first two samples' time from the record start [s].
    dt : float
        Sample interval [s].
    spectra : mapping
        ``virtual.spectra`` (``bins``, ``sn_slopes``, ``equivalent_frequency``).
    attrs : mapping
        Global attributes.
    """
    r, h, ns, bins = len(lay.labels), len(lay.holdout), len(lay.signals), spectra["bins"]
    slopes = np.array(spectra["sn_slopes"], dtype=float)
    td, f_eq = ("time", "target"), float(spectra["equivalent_frequency"])
    v = {
        "estimate": _var(td, np.zeros((2, r)), MIXED, "smoothed estimate"),
        "lower": _var(td, np.zeros((2, r)), MIXED, "lower end of the 95 % band"),
        "upper": _var(td, np.zeros((2, r)), MIXED, "upper end of the 95 % band"),
        "estimate_sd": _var(("target",), est.sd, MIXED, "standard deviation of the estimate "
                            "(steady state, offsets' uncertainty included)"),
        "steady": _var(("time",), np.zeros(2, dtype=np.int8), "1",
                       "1 where every estimate's variance is within 5 % of its steady one "
                       "(outside the start and end transients)"),
        "offset_value": _var(("offset",), est.offsets, "N m", "estimated constant offset"),
        "offset_sd": _var(("offset",), est.offsets_sd, "N m", "its standard deviation"),
        "sensor_noise_sd": _var(("sensor",), nf.noise.sensor_sd[:sensors],
                                "mixed (see sensor_units)",
                                "white-noise standard deviation (maximum likelihood)"),
        "input_noise_sd": _var(("input",), nf.noise.input_sd, "N m",
                               "motor-torque noise standard deviation (maximum likelihood)"),
        "load_step_sd": _var(("load",), nf.noise.load_rate * np.sqrt(dt), "N m",
                             "random-walk step of the unknown load per sample (maximum "
                             "likelihood)"),
        "model_noise_sd": _var((), nf.noise.model_sd, "N m", "white torque on every "
                               "coordinate: the model's error (maximum likelihood)"),
    }
    if h:
        hd, hu = ("holdout",), "mixed (see holdout_units)"
        v["holdout_measured"] = _var(("time", "holdout"), np.zeros((2, h)), hu,
                                     "held-out measurement")
        for key, unit, text in (("fit_percent", "percent", "fit, means removed (steady part)"),
                                ("fit_percent_with_mean", "percent", "fit with the means"),
                                ("rms_error", hu, "RMS error"),
                                ("coverage_95", "1", "share of held-out samples in the "
                                 "band widened by the sensor's noise")):
            v[f"holdout_{key}"] = _var(hd, np.zeros(h), unit, text)
        v["holdout_noise_sd"] = _var(hd, nf.noise.sensor_sd[sensors:], hu,
                                     "the held-out sensor's white noise (maximum likelihood)")
    sd, rd, ld = ("signal",), ("signal", "range_bin"), ("signal", "level_bin")
    v.update({
        "cycle_range": _var(rd, np.zeros((ns, bins)), "N m", "rainflow range (bin centre)"),
        "cycle_count": _var(rd, np.zeros((ns, bins)), "1", "rainflow cycles in the range bin "
                            "(half cycles count 1/2)"),
        "load_level": _var(ld, np.zeros((ns, bins)), "N m", "torque level (bin centre)"),
        "time_at_level": _var(ld, np.zeros((ns, bins)), "s", "time at level (load-duration "
                              "distribution)"),
        "del": _var(sd + ("sn_slope",), np.zeros((ns, len(slopes))), "N m",
                    f"damage-equivalent load range at {f_eq:g} Hz equivalent cycles "
                    "(N_eq = f_eq T, T the steady part's duration)"),
        "signal_source": _var(sd, np.array(["measured" if n in lay.measured else "estimated"
                                            for n in lay.signals]), "1",
                              "measured or estimated"),
    })
    c = {
        "time": ("time", time, {"units": "s", "long_name": "time from record start"}),
        "target": _var(("target",), np.array(lay.labels), "1", "estimated signal"),
        "target_units": _var(("target",), np.array(lay.units), "1", "unit of each target"),
        "offset": _var(("offset",), np.array(model.offsets, dtype=str), "1",
                       "offset (offset_<sensor> or offset_motor_torque_<motor>)"),
        "sensor": _var(("sensor",), np.array(model.measured), "1", "measured sensor"),
        "sensor_units": _var(("sensor",), np.array([model.units[m] for m in model.measured]),
                             "1", "unit of each sensor"),
        "input": _var(("input",), np.array(model.inputs), "1", "motor torque (known input)"),
        "load": _var(("load",), np.array(list(loads), dtype=str), "1",
                     "disk of an unknown load"),
        "signal": _var(("signal",), np.array(lay.signals), "1", "torque of the spectra"),
        "sn_slope": _var(("sn_slope",), slopes, "1", "S-N curve slope m"),
    }
    if h:
        c["holdout"] = _var(("holdout",), np.array(lay.holdout), "1", "held-out sensor")
        c["holdout_units"] = _var(("holdout",), np.array(
            [lay.units[lay.labels.index(x)] for x in lay.holdout]), "1", "unit")
    return xr.Dataset(v, coords=c, attrs=dict(attrs))
