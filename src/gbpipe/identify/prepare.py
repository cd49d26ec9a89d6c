"""Records -> identification data: operating point, anti-aliased decimation, harmonic removal.

The data versions of a record (``VERSIONS``, plus one per removal method named in
``identify.versions``):

* ``clean``: the simulated signals without harmonics or sensor noise;
* ``raw``: the measured-like signals (``<name>_measured``: shaft and mesh harmonics plus
  sensor noise), as a bench would log them;
* ``tsa``: the measured-like signals after removal of the configured harmonic families
  (``tsa.tests``) by joint block time-synchronous averaging with the record's own GB1 HSS
  tachometer (the ``removal_tests`` stage, :func:`gbpipe.harmonics.record_residuals`);
* ``vkf``, ``regression``, ``drs``, ``cepstrum``: the measured-like signals after removal
  of the same families by that method (the ``removal_tests`` stage,
  :mod:`gbpipe.harmonics.removal`).

All of them then go through the same :func:`condition`: subtract the operating point (the
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

import numpy as np
import xarray as xr
from scipy import signal

from gbpipe.errors import ConfigError, DataError
from gbpipe.io import measured_signal

__all__ = ["VERSIONS", "VALIDATION_PARTNER", "operating_point", "decimation_filter",
           "decimate", "decimated_times", "condition", "version_signals", "ConditionedRecord"]

#: Data versions that need no removal method of their own (``tsa`` is the paper's TSA of
#: ``tsa.tests``); any other version names a ``removal`` method run on the tests.
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
    gbpipe.errors.ConfigError
        If ``settle`` holds fewer than 10 samples or more than the record.
    """
    n0 = int(round(settle * fs))
    if n0 < 10 or n0 > len(x):
        raise ConfigError("campaign.settle", f"{settle} s gives {n0} samples at fs={fs} Hz for "
                          f"a record of {len(x)} samples: use >= 10/fs and <= the record")
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
    gbpipe.errors.ConfigError
        Non-integer factor or cutoff outside (0, 1).
    """
    ratio = fs / fs_out
    q = int(round(ratio))
    if q < 1 or abs(ratio - q) > 1e-9 * ratio:
        raise ConfigError("identify.sample_rate", f"{fs_out} Hz must divide the record rate "
                          f"{fs} Hz by an integer factor")
    if not 0 < cutoff < 1:
        raise ConfigError("identify.lowpass", f"{cutoff} must be in (0, 1) (share of the new "
                          "Nyquist)")
    if q == 1:
        return np.ones(1), 1
    # Pass band to cutoff x new Nyquist, stop band from the new Nyquist: nothing above
    # fs_out/2 folds into the band that is identified.
    numtaps = taps_per_factor * q + 1
    h = signal.firwin(numtaps, 0.5 * (1 + cutoff) * fs_out / 2, width=(1 - cutoff) * fs_out / 2,
                      fs=fs)
    return h, q


def decimated_times(n: int, fs: float, fs_out: float, cutoff: float = 0.8) -> np.ndarray:
    """When the samples :func:`decimate` makes of ``n`` input samples were taken.

    Output ``k`` is the filter output at input sample ``len(h) - 1 + q k``, which the
    linear-phase FIR delays by ``(len(h) - 1) / 2`` samples.

    Parameters
    ----------
    n : int
        Input samples.
    fs, fs_out, cutoff : float
        As :func:`decimate`.

    Returns
    -------
    ndarray
        Times of the output samples [s from the first input sample].
    """
    h, q = decimation_filter(fs, fs_out, cutoff)
    return (np.arange(len(h) - 1, n, q) - 0.5 * (len(h) - 1)) / fs


def decimate(x: np.ndarray, fs: float, fs_out: float, cutoff: float = 0.8) -> np.ndarray:
    """Causal anti-aliased decimation of ``x`` (shape (n,) or (n, channels)) along axis 0.

    Filtering and downsampling in one polyphase step (:func:`scipy.signal.upfirdn`), which
    computes only the kept samples. Output sample ``k`` is the filter output at input
    sample ``len(h) - 1 + q k``: the filter's start-up transient (one filter length) is
    dropped, so no sample sees the zero initial state. Causal (not
    :func:`scipy.signal.resample_poly`, which centres the filter): see the module notes.
    """
    x = np.asarray(x, dtype=float)
    h, q = decimation_filter(fs, fs_out, cutoff)
    if q == 1:
        return x.copy()
    first = len(h) - 1  # a multiple of q (len(h) = taps_per_factor q + 1)
    n_out = len(range(first, x.shape[0], q))
    return signal.upfirdn(h, x, up=1, down=q, axis=0)[first // q:first // q + n_out]


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


def version_signals(ds: xr.Dataset, names: Sequence[str], version: str,
                    removed: xr.Dataset | None = None) -> list[np.ndarray]:
    """The signals of one data version of a record (SI units, record rate).

    Parameters
    ----------
    ds : xarray.Dataset
        Simulated or measured record.
    names : sequence of str
        Signal names.
    version : str
        ``clean``, ``raw``, or a harmonic-removal version (``tsa``, ``vkf``, ...) whose
        output for this record is ``removed``.
    removed : xarray.Dataset, optional
        The record after harmonic removal (``removal_tests`` output:
        one variable per signal); needed for every version but ``clean`` and ``raw``.

    Raises
    ------
    ValueError
        A removal version without ``removed``, or ``clean`` of a measured record.
    gbpipe.errors.DataError
        A signal missing from the record.
    """
    if version == "raw":
        src = [measured_signal(ds, n) for n in names]
    elif version == "clean":
        if ds.attrs.get("record_kind") == "measured":
            raise ValueError("version 'clean' exists only for simulated records: a measured "
                             "record has raw (and tsa) data; set identify.versions")
        src = [ds[n] if n in ds else None for n in names]
    else:
        if removed is None:
            raise ValueError(f"version {version!r} needs the harmonic-removal output of the "
                             f"record (removed); versions: {', '.join(VERSIONS)} or a "
                             f"removal method")
        src = [removed[n] if n in removed else None for n in names]
    out = []
    for n, da in zip(names, src, strict=True):
        if da is None:
            raise DataError(n, "is not in the record; identify.pairings may only name "
                            "recorded signals")
        out.append(np.asarray(da.values, dtype=float))
    return out


class ConditionedRecord:
    """The conditioned signals of one record, each (data version, signal) computed once.

    An identify job fits every pairing x data version, and the pairings share their
    signals (each HSS speed is the output of three pairings): conditioning per pairing
    would decimate the same signal of the same version several times. Here each
    ``(version, signal)`` is conditioned (:func:`condition`, a single channel) on first
    use and kept; the decimation works channel by channel, so a stack of such columns is
    exactly :func:`condition` of the stacked signals.

    Parameters
    ----------
    ds : xarray.Dataset
        Simulated or measured record.
    removed : mapping str -> xarray.Dataset or None
        Per harmonic-removal version, the record after that removal
        (:func:`version_signals`).
    fs, settle, fs_out, cutoff : float
        Record rate [Hz], initial steady state [s], identification rate [Hz] and pass
        band [share of the new Nyquist], as in :func:`condition`.
    """

    def __init__(self, ds: xr.Dataset, removed: Mapping[str, xr.Dataset | None], fs: float,
                 settle: float, fs_out: float, cutoff: float = 0.8) -> None:
        self.ds, self.removed = ds, dict(removed)
        self.fs, self.settle, self.fs_out, self.cutoff = fs, settle, fs_out, cutoff
        self._columns: dict[tuple[str, str], np.ndarray] = {}

    def __call__(self, names: Sequence[str], version: str) -> np.ndarray:
        """Conditioned ``names`` of data version ``version``, shape (n_out, len(names)).

        Raises what :func:`version_signals` and :func:`condition` raise.
        """
        for n in dict.fromkeys(names):
            if (version, n) not in self._columns:
                # one signal at a time: of an hour-long record one full-rate signal is held
                # (the decimation is per channel, so the column is the same as in a stack)
                x = condition(version_signals(self.ds, [n], version, self.removed.get(version)),
                              self.fs, self.settle, self.fs_out, self.cutoff)
                self._columns[version, n] = x[:, 0]
        return np.column_stack([self._columns[version, n] for n in names])

    def times(self) -> np.ndarray:
        """When the conditioned samples were taken [s on the record's time axis]."""
        return float(self.ds["time"].values[0]) + decimated_times(
            self.ds.sizes["time"], self.fs, self.fs_out, self.cutoff)
