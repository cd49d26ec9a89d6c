"""A simulated-like bench record (sines + noise + an encoder + a tacho) with its known
truth, and writers that store it in each format with the format's own library."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pyuff
import scipy.io
from asammdf import MDF, Signal
from nptdms import ChannelObject, TdmsWriter

FS = 2000.0          # Hz: exact in UFF's 6-digit increment (5e-4 s)
N = 4000             # 2 s
TORQUE_DC = 1000.0   # N m
TORQUE_LINES = ((37.0, 50.0, 0.0), (113.0, 20.0, 0.3))  # (Hz, amplitude N m, phase rad)
NOISE = 0.5          # N m rms
W0, W_AMP, W_F = 30.0, 2.0, 3.0  # shaft speed 30 + 2 sin(2π 3 t) rad/s
PPR = 8
EPOCH = np.datetime64("2026-03-01T10:00:00", "ns")


@dataclass
class Bench:
    t: np.ndarray
    torque: np.ndarray        # N m
    angle: np.ndarray         # rad, cumulative
    speed: np.ndarray         # rad/s
    tacho: np.ndarray         # V
    pulses: np.ndarray        # s: true rising-edge times


def speed_true(t):
    return W0 + W_AMP * np.sin(2 * np.pi * W_F * t)


def angle_true(t):
    return W0 * t - W_AMP / (2 * np.pi * W_F) * (np.cos(2 * np.pi * W_F * t) - 1.0)


def bench(n: int = N, fs: float = FS, seed: int = 1, noise: float = NOISE) -> Bench:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    torque = TORQUE_DC + sum(a * np.sin(2 * np.pi * f * t + p) for f, a, p in TORQUE_LINES)
    torque = torque + noise * rng.standard_normal(n)
    ang = angle_true(t)
    tacho = 2.5 + 2.5 * np.tanh(4.0 * np.sin(PPR * ang))
    # true pulse k at angle 2πk/PPR (sin crosses 0 upwards), by bisection on angle_true
    k = np.arange(1, int(ang[-1] * PPR / (2 * np.pi)) + 1)
    target = 2 * np.pi * k / PPR
    lo, hi = np.zeros(k.size), np.full(k.size, t[-1])
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = angle_true(mid) < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return Bench(t, torque, ang, speed_true(t), tacho, 0.5 * (lo + hi))


def torque_true(t: np.ndarray) -> np.ndarray:
    """Noise-free torque at any time [N m]."""
    return TORQUE_DC + sum(a * np.sin(2 * np.pi * f * t + p) for f, a, p in TORQUE_LINES)


def line_amplitude(x: np.ndarray, t: np.ndarray, f: float) -> float:
    """Least-squares amplitude of the f-Hz sine in x (independent of any gbpipe code)."""
    a = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t),
                         np.ones_like(t)])
    c = np.linalg.lstsq(a, x, rcond=None)[0]
    return float(np.hypot(c[0], c[1]))


def write_tdms(path: Path, b: Bench, *, start_offset: float = 0.0, epoch=EPOCH,
               torque_scale: float = 1e-3, segments: int = 2) -> None:
    """Torque in kN*m and the tacho in V, waveform properties, written in segments."""
    props = {"wf_increment": 1.0 / FS, "wf_start_offset": start_offset}
    if epoch is not None:
        props["wf_start_time"] = epoch
    with TdmsWriter(path) as w:
        for idx in np.array_split(np.arange(b.t.size), segments):
            w.write_segment([
                ChannelObject("Measurements", "Torque", b.torque[idx] * torque_scale,
                              properties={**props, "unit_string": "kN*m"}),
                ChannelObject("Measurements", "Tacho", b.tacho[idx],
                              properties={**props, "unit_string": "V"})])


def write_tdms_array_column(path: Path, b: Bench) -> None:
    """NI_ArrayColumn layout: both columns interleaved in column 0, column 1 empty."""
    inter = np.column_stack([b.torque, b.tacho]).ravel()  # row-major: t0 c0, t0 c1, ...
    props = {"wf_increment": 1.0 / FS}
    with TdmsWriter(path) as w:
        w.write_segment([
            ChannelObject("Array", "Torque", inter,
                          properties={**props, "NI_ArrayColumn": np.int32(0),
                                      "unit_string": "N*m"}),
            ChannelObject("Array", "Tacho", np.array([], dtype=float),
                          properties={**props, "NI_ArrayColumn": np.int32(1),
                                      "unit_string": "V"})])


def write_csv(path: Path, columns: dict[str, np.ndarray], *, sep: str = ",",
              decimal: str = ".") -> None:
    pd.DataFrame(columns).to_csv(path, sep=sep, decimal=decimal, index=False,
                                 float_format="%.12g")


def write_uff(path: Path, b: Bench, *, binary: int = 1) -> None:
    sets = []
    for name, data, unit in (("Torque", b.torque, "N*m"), ("Encoder", np.degrees(b.angle),
                                                           "deg")):
        sets.append(pyuff.prepare_58(
            binary=binary, id1=name, func_type=1, rsp_node=1, rsp_dir=1, ref_node=0,
            ref_dir=0, data=data, x=b.t, abscissa_spacing=1, abscissa_spec_data_type=17,
            abscissa_axis_units_lab="s", ordinate_spec_data_type=1,
            ordinate_axis_units_lab=unit, orddenom_spec_data_type=0))
    path.unlink(missing_ok=True)
    pyuff.UFF(str(path)).write_sets(sets, mode="add")  # pyuff's binary overwrite is buggy


def write_mat(path: Path, b: Bench) -> None:
    scipy.io.savemat(path, {"torque": b.torque, "both": np.column_stack([b.tacho, b.torque]),
                            "t": b.t})


def write_testlab_mat(path: Path, b: Bench) -> None:
    """Simcenter Testlab export layout: one struct per signal, x_values / y_values."""
    sig = {"x_values": {"start_value": 0.0, "increment": 1.0 / FS,
                        "number_of_values": b.t.size,
                        "quantity": {"label": "s"}},
           "y_values": {"values": b.torque / 1000.0,
                        "quantity": {"label": "N*m", "unit_transformation": {
                            "factor": 1000.0, "offset": 0.0, "log_reference": 1.0}}},
           "function_record": {"name": "Torque", "type": "Time"}}
    scipy.io.savemat(path, {"Signal": sig})


def write_mat73(path: Path, b: Bench) -> None:
    """MATLAB v7.3 layout: HDF5 with a 512-byte user block, arrays stored transposed."""
    with h5py.File(path, "w", userblock_size=512) as f:
        d = f.create_dataset("torque", data=b.torque[None, :])  # MATLAB (n, 1)
        d.attrs["MATLAB_class"] = np.bytes_("double")
        d = f.create_dataset("both", data=np.column_stack([b.tacho, b.torque]).T)
        d.attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, created by the gbpipe tests".ljust(116))


def write_mdf(path: Path, b: Bench) -> None:
    m = MDF(version="4.10")
    m.append([Signal(b.torque, b.t, unit="N*m", name="Torque"),
              Signal(np.degrees(b.angle), b.t, unit="deg", name="Encoder")])
    m.save(path, overwrite=True)
