"""Records -> identification data: operating point, anti-aliased decimation, harmonic removal.

Three data versions of a record are identified (``VERSIONS``):

* ``clean``: the simulated signals without harmonics or sensor noise;
* ``raw``: the measured-like signals (``<name>_measured``: shaft and mesh harmonics plus
  sensor noise), as a bench would log them;
* ``tsa``: the measured-like signals after removal of the configured harmonic families
  (``tsa.tests``) by joint block time-synchronous averaging with the record's own GB1 HSS
  tachometer (:func:`gbpipe.tsa.residual_joint`).

All three then go through the same :func:`condition`: subtract the operating point (the
mean over the initial steady-state ``settle`` seconds, *not* the record mean: the
torque -> speed model has a rigid-body integrator, and the record mean of a step test is
not an equilibrium) and decimate with a causal linear-phase FIR anti-aliasing filter.
A causal filter, applied identically to every channel, leaves the input -> output
transfer function unchanged (the common delay cancels), and keeps the closed-loop data
causal; a zero-phase (non-causal) filter would smear the feedback's dependence on the
current noise into "past" samples, which the closed-loop consistency of PBSID relies on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["VERSIONS", "VALIDATION_PARTNER", "operating_point", "decimation_filter",
           "decimate", "condition", "tsa_residuals", "version_signals"]

#: Data versions identified for every record.
VERSIONS = ("clean", "raw", "tsa")

#: Validation record of each test: the mirror test of the same profile, never seen in fitting.
VALIDATION_PARTNER = {"speed_up": "speed_down", "speed_down": "speed_up",
                      "torque_up": "torque_down", "torque_down": "torque_up"}


def operating_point(x: np.ndarray, fs: float, settle: float) -> float:
    """Mean of ``x`` over the initial ``settle`` seconds (steady state at the nominal point).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Signal in its own unit.
    fs : float
        Sample rate [Hz].
    settle : float
        Duration of the initial steady state [s], > 0.

    Raises
    ------
    ValueError
        If ``settle`` holds fewer than 10 samples or more than the record.
    """
    n0 = int(round(settle * fs))
    if n0 < 10 or n0 > len(x):
        raise ValueError(f"settle={settle} s gives {n0} samples at fs={fs} Hz for a record of "
                         f"{len(x)} samples: use campaign.settle >= 10/fs and <= the record")
    return float(np.mean(x[:n0]))


def decimation_filter(fs: float, fs_out: float, cutoff: float = 0.8,
                      taps_per_factor: int = 40) -> tuple[np.ndarray, int]:
    """Linear-phase FIR low-pass for decimation from ``fs`` to ``fs_out`` [Hz].

    Parameters
    ----------
    fs, fs_out : float
        Input and output sample rates [Hz]; ``fs / fs_out`` must be an integer.
    cutoff : float
        Pass-band edge as a share of the output Nyquist frequency (0.8: 400 Hz at 1 kHz).
    taps_per_factor : int
        Filter length per unit of decimation factor (sharper transition when larger).

    Returns
    -------
    h : ndarray
        Filter taps.
    q : int
        Decimation factor.

    Raises
    ------
    ValueError
        Non-integer factor or cutoff outside (0, 1).
    """
    from scipy import signal

    ratio = fs / fs_out
    q = int(round(ratio))
    if q < 1 or abs(ratio - q) > 1e-9 * ratio:
        raise ValueError(f"identify.sample_rate={fs_out} Hz must divide the record rate {fs} Hz "
                         "by an integer factor")
    if not 0 < cutoff < 1:
        raise ValueError(f"identify.lowpass={cutoff} must be in (0, 1) (share of the new Nyquist)")
    if q == 1:
        return np.ones(1), 1
    # Pass band to cutoff x new Nyquist, stop band from the new Nyquist: nothing above
    # fs_out/2 folds into the band that is identified.
    numtaps = taps_per_factor * q + 1
    h = signal.firwin(numtaps, 0.5 * (1 + cutoff) * fs_out / 2, width=(1 - cutoff) * fs_out / 2,
                      fs=fs)
    return h, q


def decimate(x: np.ndarray, fs: float, fs_out: float, cutoff: float = 0.8) -> np.ndarray:
    """Causal anti-aliased decimation of ``x`` (shape (n,) or (n, channels)) along axis 0."""
    from scipy import signal

    h, q = decimation_filter(fs, fs_out, cutoff)
    xf = signal.lfilter(h, [1.0], np.asarray(x, dtype=float), axis=0) if q > 1 else x
    # drop the filter's start-up transient (one filter length) so no sample sees the zero
    # initial state
    return np.asarray(xf)[len(h) - 1::q].copy() if q > 1 else np.array(xf, dtype=float)


def condition(signals: Sequence[np.ndarray], fs: float, settle: float, fs_out: float,
              cutoff: float = 0.8, offsets: Sequence[float] | None = None) -> np.ndarray:
    """Stack signals as channels, subtract the operating point, decimate.

    Parameters
    ----------
    signals : sequence of ndarray, each shape (n,)
        Signals in SI units at ``fs``.
    fs : float
        Record sample rate [Hz].
    settle : float
        Initial steady-state duration [s] (operating point).
    fs_out : float
        Identification sample rate [Hz].
    cutoff : float
        Anti-aliasing pass band, share of the new Nyquist.
    offsets : sequence of float, optional
        Operating point per signal; default from the first ``settle`` seconds of each.

    Returns
    -------
    ndarray, shape (n_out, channels)
    """
    x = np.column_stack([np.asarray(s, dtype=float) for s in signals])
    if offsets is None:
        offsets = [operating_point(x[:, i], fs, settle) for i in range(x.shape[1])]
    return decimate(x - np.asarray(offsets)[None, :], fs, fs_out, cutoff)


def tsa_residuals(ds, names: Sequence[str], stages: Sequence[Mapping[str, Any]],
                  tsa_cfg: Mapping[str, Any], keep_below: float = 0.5
                  ) -> dict[str, np.ndarray]:
    """Measured-like signals after joint TSA removal of the ``tsa.tests`` families.

    Parameters
    ----------
    ds : xarray.Dataset
        A simulated record with ``<name>_measured``, ``pulse_time`` and attribute
        ``pulses_per_rev``.
    names : sequence of str
        Signal names (without ``_measured``).
    stages : sequence of mapping
        Gearbox stages (for the exact cycle orders).
    tsa_cfg : mapping
        ``cfg["tsa"]``: ``tests`` (cycle names), ``n_cycles``, ``unbiased``.
    keep_below : float
        TSA acts only on the part of each signal above ``keep_below`` times the lowest
        removed cycle frequency at the record's mean HSS speed (split by a zero-phase
        Butterworth low-pass; the low part is added back unchanged; 0 disables the split).
        Why: each block's mean cycle also averages whatever else is in the block; for a
        step test that is the bench's slow step response, whose trend inside a 10-cycle
        block becomes a sawtooth at the cycle rate in the mean cycle, and whose block
        means form a staircase -- subtracting both would inject broadband errors far
        larger than the harmonics. Every harmonic lies at or above the lowest cycle
        frequency, so the split loses none of them.

    Returns
    -------
    dict
        Name -> residual at the record's sample rate, unit of the signal.
    """
    from scipy import signal

    from gbpipe import tsa
    from gbpipe.kinematics import order_of

    fs = float(ds.attrs["sample_rate"])
    pulses = np.asarray(ds["pulse_time"].values, dtype=float)
    ppr = int(ds.attrs.get("pulses_per_rev", 1))
    cycles = [order_of(stages, c) for c in tsa_cfg["tests"]]
    f_hss = float(np.mean(ds["speed_gb1_hss"].values)) / (2 * np.pi)
    f_low = keep_below * min(float(c) for c in cycles) * f_hss
    sos = signal.butter(6, f_low, fs=fs, output="sos") if keep_below > 0 else None
    out = {}
    for name in names:
        x = np.asarray(ds[f"{name}_measured"].values, dtype=float)
        if not cycles:
            out[name] = x
            continue
        low = signal.sosfiltfilt(sos, x) if sos is not None else np.zeros_like(x)
        r = low + tsa.residual_joint(x - low, fs, pulses, cycles, int(tsa_cfg["n_cycles"]),
                                     ppr, unbiased=bool(tsa_cfg.get("unbiased", False)),
                                     outside="keep")
        out[name] = r
    return out


def version_signals(ds, names: Sequence[str], version: str,
                    tsa_ds=None) -> list[np.ndarray]:
    """The signals of one data version of a record (SI units, record rate).

    Parameters
    ----------
    ds : xarray.Dataset
        Simulated record.
    names : sequence of str
        Signal names.
    version : {"clean", "raw", "tsa"}
    tsa_ds : xarray.Dataset, optional
        Output of the ``tsa_tests`` stage for this record (needed for ``tsa``).

    Raises
    ------
    ValueError
        Unknown version, or a missing signal.
    """
    if version not in VERSIONS:
        raise ValueError(f"unknown data version {version!r}; use one of {', '.join(VERSIONS)}")
    if version == "tsa":
        if tsa_ds is None:
            raise ValueError("version 'tsa' needs the tsa_tests output of the record (tsa_ds)")
        src, fmt = tsa_ds, "{}"
    else:
        src, fmt = ds, ("{}" if version == "clean" else "{}_measured")
    out = []
    for n in names:
        key = fmt.format(n)
        if key not in src:
            raise ValueError(f"signal {key!r} is not in the record; identify.pairings may only "
                             f"name recorded signals")
        out.append(np.asarray(src[key].values, dtype=float))
    return out
