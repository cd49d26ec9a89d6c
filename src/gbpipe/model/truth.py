"""The true linear model of each identification pairing, and its FRF and modes as data.

Identification from recorded motor torques to speeds sees the bench *inside* its control
loops. The recorded driver torque is the speed controller's output (plus ripple), so the
system between it and the speeds is the bench with the speed loop opened at the motor
torque and the braking-torque loop still closed; likewise for the driven torque. With
:func:`gbpipe.model.bench_ss` that is, for the paper's two motors (any drivetrain alike:
the loops of the pairing's motors opened, the others closed):

* ``motor_torque_driver`` alone: speed gains (0, 0); then the input ``disturbance_driver``
  *is* the driver motor torque;
* ``motor_torque_driven`` alone: torque gains (0, 0); ``disturbance_driven`` is the braking
  torque (its feed-forward share of ``torque_ref`` enters through ``torque_ref``, which is
  not an input of the pairing);
* both torques: the open-loop plant.

Zeroed controller integrators stay in the state vector as uncontrollable poles at s = 0:
harmless for FRFs, and excluded from the modal comparison (:func:`true_modes`).
The model stage writes :func:`truth_dataset` to ``results/model/truth.nc``; the
identification stage reads it (docs/architecture.md, "Data contract").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.lti import NamedSS, frf, modes
from gbpipe.model.assembly import bench_chain
from gbpipe.model.statespace import chain_plant, close_loops

__all__ = ["TORQUES", "truth_model", "true_modes", "truth_dataset"]

#: The paper bench's motor torques usable as identification inputs -> closed-loop input
#: that equals them when their own loop's gains are zero (a drivetrain's are
#: ``motor_torque_<motor>`` -> ``disturbance_<motor>`` of its motors).
TORQUES = {"motor_torque_driver": "disturbance_driver",
           "motor_torque_driven": "disturbance_driven"}


def truth_model(cfg: Mapping[str, Any], inputs: Sequence[str],
                outputs: Sequence[str]) -> NamedSS:
    """True continuous-time model from the pairing's inputs to its outputs.

    The loops of the input motors are opened (gains zero: their ``disturbance_<motor>``
    is then their torque), the others stay closed; with every motor an input, the
    open-loop plant.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``, or ``drivetrain``).
    inputs : sequence of str
        Motor torques ``motor_torque_<motor>`` [N·m] (the paper: one or both of
        ``motor_torque_driver``, ``motor_torque_driven``).
    outputs : sequence of str
        Bench outputs, e.g. ``speed_gb1_hss``, ``speed_gb2_hss`` [rad/s].

    Returns
    -------
    NamedSS
        Inputs named as in the records (the motor torques), outputs as given.

    Raises
    ------
    ValueError
        An input that is not a motor torque, a repeated input, or an unknown output.
    """
    inputs, outputs = list(inputs), list(outputs)
    chain = bench_chain(cfg)
    torques = {m.input: m for m in chain.motors}
    bad = [u for u in inputs if u not in torques]
    if bad or not inputs or len(set(inputs)) != len(inputs):
        raise ValueError(f"identify.pairings inputs {inputs} must be some of "
                         f"{', '.join(torques)} (each once)")
    plant = chain_plant(chain)
    if len(inputs) == len(torques):
        ss = plant.select(inputs, outputs)
    else:
        opened = {torques[u].name: (0.0, 0.0) for u in inputs}
        ss = close_loops(plant, chain.motors, opened).select(
            [f"disturbance_{torques[u].name}" for u in inputs], outputs)
    ss.units.update({u: "N m" for u in inputs})
    ss.inputs = inputs
    return ss


def true_modes(A: np.ndarray, f_max: float, zeta_max: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Oscillatory modes of a continuous state matrix up to ``f_max`` [Hz].

    Poles at s = 0 (rigid body, zeroed integrators) and real poles are not modes.
    Modes with damping ratio above ``zeta_max`` are left out (not resonances one can see
    in an FRF); a negative damping ratio (a loop that is unstable on its own) is kept.

    Returns
    -------
    freq_hz, zeta : ndarray
        Natural frequencies [Hz] (ascending) and damping ratios [-].
    """
    f, z = modes(A)
    keep = (f <= f_max) & (z <= zeta_max)
    return f[keep], z[keep]


def truth_dataset(cfg: Mapping[str, Any], pairings: Sequence[Mapping[str, Any]],
                  f_hz: Any, f_max: float, zeta_max: float) -> xr.Dataset:
    """True FRFs and modes of every identification pairing, on the identification grid.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``).
    pairings : sequence of mapping
        ``identify.pairings``: each with ``name``, ``inputs``, ``outputs``.
    f_hz : array_like
        Frequency grid of the identification FRFs [Hz].
    f_max : float
        Highest mode frequency kept [Hz].
    zeta_max : float
        Highest damping ratio kept [-].

    Returns
    -------
    xarray.Dataset
        ``frf_true_real``, ``frf_true_imag`` on (pairing, frequency, output, input) in
        output units per input unit (``output_units``, ``input_units``);
        ``mode_frequency_true`` [Hz] and ``mode_damping_true`` [1] on (pairing, mode);
        the names of each pairing's signals in ``output_name``/``input_name``. Pairings
        with fewer signals or modes than the largest are padded with NaN (names with
        ``""``).
    """
    f = np.atleast_1d(np.asarray(f_hz, dtype=float))
    names = [str(p["name"]) for p in pairings]
    models = [truth_model(cfg, p["inputs"], p["outputs"]) for p in pairings]
    found = [true_modes(m.A, f_max, zeta_max) for m in models]
    n_p, n_o = len(models), max(len(m.outputs) for m in models)
    n_i, n_m = max(len(m.inputs) for m in models), max(fm.size for fm, _ in found)
    g = np.full((n_p, f.size, n_o, n_i), np.nan, dtype=complex)
    fm_all, zm_all = np.full((n_p, n_m), np.nan), np.full((n_p, n_m), np.nan)
    out_name, in_name = np.full((n_p, n_o), "", dtype=object), np.full((n_p, n_i), "",
                                                                         dtype=object)
    out_unit, in_unit = out_name.copy(), in_name.copy()
    for k, (m, (fm, zm)) in enumerate(zip(models, found, strict=True)):
        g[k, :, :len(m.outputs), :len(m.inputs)] = frf(m, f)
        fm_all[k, :fm.size], zm_all[k, :zm.size] = fm, zm
        out_name[k, :len(m.outputs)], in_name[k, :len(m.inputs)] = m.outputs, m.inputs
        out_unit[k, :len(m.outputs)] = [m.units[o] for o in m.outputs]
        in_unit[k, :len(m.inputs)] = [m.units[i] for i in m.inputs]
    dims = ("pairing", "frequency", "output", "input")
    frf_attrs = {"units": "mixed (see output_units, input_units)"}
    return xr.Dataset(
        {
            "frf_true_real": (dims, g.real, {**frf_attrs, "long_name":
                                             "real part of the true frequency response"}),
            "frf_true_imag": (dims, g.imag, {**frf_attrs, "long_name":
                                             "imaginary part of the true frequency response"}),
            "mode_frequency_true": (("pairing", "mode"), fm_all, {
                "units": "Hz", "long_name": "undamped natural frequency of the true modes"}),
            "mode_damping_true": (("pairing", "mode"), zm_all, {
                "units": "1", "long_name": "damping ratio of the true modes"}),
        },
        coords={
            "pairing": ("pairing", names, {"units": "1", "long_name": "signal pairing"}),
            "frequency": ("frequency", f, {"units": "Hz", "long_name": "frequency"}),
            "output": ("output", np.arange(n_o), {"units": "1", "long_name": "output index"}),
            "input": ("input", np.arange(n_i), {"units": "1", "long_name": "input index"}),
            "mode": ("mode", np.arange(n_m), {"units": "1", "long_name": "mode number"}),
            "output_name": (("pairing", "output"), out_name.astype(str),
                            {"units": "1", "long_name": "output signal"}),
            "input_name": (("pairing", "input"), in_name.astype(str),
                           {"units": "1", "long_name": "input signal"}),
            "output_units": (("pairing", "output"), out_unit.astype(str),
                             {"units": "1", "long_name": "unit of the output"}),
            "input_units": (("pairing", "input"), in_unit.astype(str),
                            {"units": "1", "long_name": "unit of the input"}),
        },
        attrs={"f_max": float(f_max), "zeta_max": float(zeta_max)},
    )
