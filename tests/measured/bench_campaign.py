"""Bench files from a simulated test record, as a test bench would log them.

The measured-like signals of a simulated record (harmonics and sensor noise included)
are written the way ``config/examples/measured.yaml`` maps them: the motor torques in a
CSV in kN*m, the driving-side encoder as a cumulative angle in degrees in a second CSV
with its own, jittered time stamps, and the driving-side torque meter with the GB1 HSS
tachometer voltage in a TDMS file with waveform properties. The truth is the record
itself, so a test can compare what :func:`gbpipe.measured.read` gives back.

Run as a script to write the example's files: ``python tests/measured/bench_campaign.py
bench/`` (simulates the ``speed_up``/``square`` test of ``config/config.yaml`` overlaid by
``config/ci.yaml``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from nptdms import ChannelObject, TdmsWriter
from scipy.integrate import cumulative_trapezoid

EPOCH = np.datetime64("2026-06-01T08:00:00", "ns")
JITTER = 2e-6  # s rms: time-stamp jitter of the encoder logger


def tacho_voltage(t: np.ndarray, speed: np.ndarray, ppr: int) -> np.ndarray:
    """A smooth 0-5 V tacho whose rising mid-level crossings are the pulses of a shaft
    turning at ``speed`` [rad/s] with ``ppr`` pulses per revolution."""
    return tacho_of_angle(cumulative_trapezoid(speed, t, initial=0.0), ppr)


def tacho_of_angle(theta: np.ndarray, ppr: int) -> np.ndarray:
    """The 0-5 V tacho of :func:`tacho_voltage` of a shaft at angle ``theta`` [rad]."""
    return 2.5 + 2.5 * np.sin(ppr * theta + 0.3)


def write_campaign_files(record: xr.Dataset, folder: Path, *, seed: int = 7) -> dict:
    """Write the bench files of the example from a simulated record; return the truth.

    Returns
    -------
    dict
        Signal name -> the values the files encode [SI], on the record's time grid.
    """
    folder.mkdir(parents=True, exist_ok=True)
    t = record.time.values
    fs = float(record.attrs["sample_rate"])
    rng = np.random.default_rng(seed)
    m = {n: record[f"{n}_measured"].values for n in
         ("motor_torque_driver", "motor_torque_driven", "torque_meter_driving",
          "speed_gb2_hss", "speed_gb1_hss")}
    pd.DataFrame({"time": t, "drive torque": m["motor_torque_driver"] / 1e3,
                  "brake torque": m["motor_torque_driven"] / 1e3}).to_csv(
        folder / "run12_motors.csv", index=False, float_format="%.12g")
    angle = np.degrees(cumulative_trapezoid(m["speed_gb2_hss"], t, initial=0.0))
    t_enc = t + rng.normal(0.0, JITTER, t.size)
    pd.DataFrame({"time": t_enc, "encoder 1": angle}).to_csv(
        folder / "run12_sensors.csv", index=False, float_format="%.12g")
    ppr = int(record.attrs["pulses_per_rev"])
    tacho = tacho_voltage(t, record["speed_gb1_hss"].values, ppr)
    props = {"wf_increment": 1.0 / fs, "wf_start_offset": 0.0, "wf_start_time": EPOCH}
    with TdmsWriter(folder / "run12.tdms") as w:
        w.write_segment([
            ChannelObject("Measurements", "Torque", m["torque_meter_driving"] / 1e3,
                          properties={**props, "unit_string": "kN*m"}),
            ChannelObject("Measurements", "Tacho", tacho,
                          properties={**props, "unit_string": "V"})])
    return {"motor_torque_driver": m["motor_torque_driver"],
            "motor_torque_driven": m["motor_torque_driven"],
            "torque_meter": m["torque_meter_driving"], "speed_motor": m["speed_gb2_hss"]}


if __name__ == "__main__":
    from gbpipe.config import load
    from gbpipe.simulate import test

    root = Path(__file__).resolve().parents[2]
    cfg = load(root / "config" / "config.yaml", root / "config" / "ci.yaml")
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "bench")
    write_campaign_files(test(cfg, "speed_up", "square", measured_like=True), out)
    print(f"bench files written to {out}/")
