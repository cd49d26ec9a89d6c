"""xarray form of the model stage: state-space matrices, modes and FRFs with units."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from gbpipe.lti import NamedSS, frf, modes
from gbpipe.model.mechanics import Mechanism

__all__ = ["statespace_dataset", "frequency_grid"]


def frequency_grid(f_min: float, f_max: float, points: int) -> np.ndarray:
    """Log-spaced frequency grid [Hz]."""
    return np.geomspace(f_min, f_max, points)


def statespace_dataset(ss: NamedSS, f_hz: np.ndarray, prefix: str = "",
                       mech: Mechanism | None = None,
                       frf_inputs: Sequence[str] | None = None,
                       frf_outputs: Sequence[str] | None = None) -> xr.Dataset:
    """Matrices, modes and FRF magnitude/phase of a named state space.

    Parameters
    ----------
    ss : NamedSS
    f_hz : ndarray
        FRF grid [Hz].
    prefix : str
        Prefix of variable and dimension names (``gearbox_``, ``bench_`` …) so that
        several systems can share a file.
    mech : Mechanism, optional
        Adds the undamped natural frequencies from ``K v = ω² M v``.
    frf_inputs, frf_outputs : sequence of str, optional
        Restrict the stored FRFs.
    """
    p = prefix
    sub = ss.select(list(frf_inputs) if frf_inputs else None,
                    list(frf_outputs) if frf_outputs else None)
    G = frf(sub, f_hz)
    fn, zeta = modes(ss.A)
    unit_of = ss.units.get
    ds = xr.Dataset(
        {
            f"{p}A": ((f"{p}state", f"{p}state_from"), ss.A,
                      {"units": f"mixed (see {p}state_units)", "long_name": "state matrix A"}),
            f"{p}B": ((f"{p}state", f"{p}input"), ss.B,
                      {"units": f"mixed (see {p}state_units, {p}input_units)",
                       "long_name": "input matrix B"}),
            f"{p}C": ((f"{p}output", f"{p}state"), ss.C,
                      {"units": f"mixed (see {p}output_units, {p}state_units)",
                       "long_name": "output matrix C"}),
            f"{p}D": ((f"{p}output", f"{p}input"), ss.D,
                      {"units": f"mixed (see {p}output_units, {p}input_units)",
                       "long_name": "feedthrough matrix D"}),
            f"{p}mode_frequency": (f"{p}mode", fn,
                                   {"units": "Hz", "long_name": "undamped natural frequency "
                                    "of the damped modes"}),
            f"{p}mode_damping": (f"{p}mode", zeta,
                                 {"units": "1", "long_name": "modal damping ratio"}),
            f"{p}frf_magnitude": (("frequency", f"{p}frf_output", f"{p}frf_input"),
                                  20 * np.log10(np.abs(G) + 1e-300),
                                  {"units": "dB", "long_name": "FRF magnitude, 20 log10 |G| "
                                   "in the units of output per input"}),
            f"{p}frf_phase": (("frequency", f"{p}frf_output", f"{p}frf_input"),
                              np.degrees(np.angle(G)),
                              {"units": "degree", "long_name": "FRF phase"}),
        },
        coords={
            "frequency": ("frequency", f_hz, {"units": "Hz", "long_name": "frequency"}),
            f"{p}state": (f"{p}state", ss.states, {"units": "1", "long_name": "state"}),
            f"{p}state_from": (f"{p}state_from", ss.states,
                               {"units": "1", "long_name": "state (column of A)"}),
            f"{p}state_units": (f"{p}state", [unit_of(s, "1") for s in ss.states],
                                {"units": "1", "long_name": "unit of the state"}),
            f"{p}input": (f"{p}input", ss.inputs, {"units": "1", "long_name": "input"}),
            f"{p}input_units": (f"{p}input", [unit_of(s, "1") for s in ss.inputs],
                                {"units": "1", "long_name": "unit of the input"}),
            f"{p}output": (f"{p}output", ss.outputs, {"units": "1", "long_name": "output"}),
            f"{p}output_units": (f"{p}output", [unit_of(s, "1") for s in ss.outputs],
                                 {"units": "1", "long_name": "unit of the output"}),
            f"{p}frf_input": (f"{p}frf_input", sub.inputs,
                              {"units": "1", "long_name": "FRF input"}),
            f"{p}frf_output": (f"{p}frf_output", sub.outputs,
                               {"units": "1", "long_name": "FRF output"}),
            f"{p}mode": (f"{p}mode", np.arange(fn.size),
                         {"units": "1", "long_name": "mode number"}),
        },
    )
    if mech is not None:
        fu = mech.undamped_frequencies()
        ds[f"{p}undamped_frequency"] = (f"{p}undamped_mode", fu, {
            "units": "Hz", "long_name": "undamped natural frequency from K v = w^2 M v"})
        ds = ds.assign_coords({f"{p}undamped_mode": (f"{p}undamped_mode", np.arange(fu.size),
                                                     {"units": "1", "long_name": "mode"})})
    return ds
