"""Power spectral densities of the signals that drive the bench, for the design step.

One-sided PSDs [unit² / Hz] on a frequency grid, from the configuration (``noise``) or from
a set-point signal, as :func:`gbpipe.identify.design.predict` needs them:

* a white sequence of rms ``s`` at the sample rate ``fs`` (the motor ripple's broadband
  part, the sensor noise): ``s² / (fs / 2)`` up to ``fs / 2`` (Parseval);
* a pulsating ripple line of amplitude ``a`` [N·m] at harmonic ``h`` of the electrical
  frequency ``p · f_rot`` (``p`` pole pairs, ``f_rot`` the motor shaft rotation frequency):
  power ``a² / 2`` spread evenly over the frequencies the line crosses in the test, widened
  by the analysis resolution;
* a speed differenced from an encoder angle quantised to ``q = 2 π / counts_per_rev``
  [rad]: the quantisation error ``e`` is white, uniform, variance ``q² / 12`` (Widrow &
  Kollár, *Quantization Noise*, 2008, ch. 4; valid when the angle moves many counts per
  sample), and ``ω_k = (θ_k − θ_{k−1}) fs`` passes it through ``(1 − z⁻¹) fs``, whose gain
  is ``|1 − e^{−j2πf/fs}|² fs² = 4 fs² sin²(π f / fs)``; with the one-sided PSD of ``e``,
  ``2 (q² / 12) / fs``, the speed noise PSD is ``(2 q² / 3) fs sin²(π f / fs)``;
* the angle-locked gear excitation (``excitation``: shaft orders as an angle error across
  each HSS coupling, mesh transmission errors with their harmonics) [rad]: each line of
  HSS order ``o`` and amplitude ``a`` at ``excitation.load_reference``, scaled with the
  braking-torque set-point as the simulator does, is a line of amplitude
  ``a · rms(torque_ref / load_reference)`` spread like a ripple line over ``o · f_rot``;
* a harmonic-removal version (TSA, a removal method) takes off every line whose HSS order
  is a whole multiple of one of its cycles' orders (:func:`gbpipe.kinematics.whole_multiple`,
  as for the harmonic families), the motors' pulsating lines included;
* a set-point (step, ramp, designed multisine or PRBS): Welch's average periodogram
  (:func:`scipy.signal.welch`), Hann segments of ``1 / resolution`` seconds overlapping by
  3/4 (the squared Hann windows then sum to a constant, so a step anywhere in the record
  weighs the same), interpolated to the grid.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np
from scipy.signal import welch

from gbpipe.errors import ConfigError
from gbpipe.kinematics import excitation_lines, pulsating_orders, whole_multiple

__all__ = ["white_psd", "quantised_speed_psd", "line_psd", "ripple_psd", "excitation_psds",
           "sensor_psds", "reference_psd"]


def white_psd(rms: float, fs: float, f_hz: np.ndarray) -> np.ndarray:
    """One-sided PSD ``rms² / (fs / 2)`` of white noise of ``rms`` at ``fs`` [Hz].

    Zero above ``fs / 2`` (nothing of a sampled sequence lies there).
    """
    f = np.asarray(f_hz, dtype=float)
    return np.where(f <= fs / 2, float(rms) ** 2 / (fs / 2), 0.0)


def quantised_speed_psd(f_hz: np.ndarray, counts_per_rev: float, fs: float) -> np.ndarray:
    """One-sided PSD [(rad/s)² / Hz] of a speed differenced from a quantised angle.

    ``(2 q² / 3) fs sin²(π f / fs)`` with ``q = 2 π / counts_per_rev`` [rad] (module
    docstring).
    """
    q = 2 * np.pi / float(counts_per_rev)
    f = np.asarray(f_hz, dtype=float)
    return np.where(f <= fs / 2, 2 * q ** 2 / 3 * fs * np.sin(np.pi * f / fs) ** 2, 0.0)


def line_psd(f_hz: np.ndarray, f_lo: float, f_hi: float, amplitude: float,
             resolution: float) -> np.ndarray:
    """A sinusoid of ``amplitude`` whose frequency moves within ``[f_lo, f_hi]`` [Hz].

    Its power ``amplitude² / 2`` spread evenly over ``[f_lo − res/2, f_hi + res/2]``.
    """
    lo, hi = f_lo - resolution / 2, f_hi + resolution / 2
    f = np.asarray(f_hz, dtype=float)
    return np.where((f >= lo) & (f <= hi), float(amplitude) ** 2 / 2 / (hi - lo), 0.0)


def ripple_psd(ripple: Any, fs: float, f_hz: np.ndarray, rotation_hz: tuple[float, float],
               resolution: float, field: str = "noise.motor_ripple",
               removed: Sequence[Fraction] = ()) -> np.ndarray:
    """PSD [(N·m)² / Hz] of one motor's torque ripple.

    Parameters
    ----------
    ripple : float or mapping
        ``noise.motor_ripple.<motor>``: a number (broadband rms [N·m] only) or a mapping
        with ``broadband`` [N·m rms], ``pole_pairs`` and ``pulsating`` (list of
        ``{harmonic, amplitude [N·m]}``; harmonics of the electrical frequency).
    fs : float
        Sample rate the ripple is white at [Hz] (``campaign.sample_rate``).
    f_hz : ndarray
        Grid [Hz].
    rotation_hz : (float, float)
        Lowest and highest motor shaft rotation frequency of the test [Hz].
    resolution : float
        Analysis resolution [Hz] a line is widened by.
    field : str
        Config path, for messages.
    removed : sequence of Fraction
        Cycle orders of a harmonic removal: the pulsating lines it takes off are left out.
    """
    if isinstance(ripple, (int, float)):
        return white_psd(float(ripple), fs, f_hz)
    if not isinstance(ripple, Mapping) or "broadband" not in ripple:
        raise ConfigError(field, f"must be a number or a mapping with 'broadband', got "
                                 f"{ripple!r}; see config/README.md")
    psd = white_psd(float(ripple["broadband"]), fs, f_hz)
    try:
        lines = pulsating_orders(ripple)
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"{field}.pulsating", "needs 'harmonic' and 'amplitude' in every "
                          "line (and an integer pole_pairs)") from exc
    for order, amplitude in lines:
        if not whole_multiple(order, removed):
            psd = psd + line_psd(f_hz, order * rotation_hz[0], order * rotation_hz[1],
                                 amplitude, resolution)
    return psd


def excitation_psds(excitation: Mapping[str, Any], stages: Sequence[Mapping[str, Any]],
                    inputs: Sequence[str], f_hz: np.ndarray, rotation_hz: tuple[float, float],
                    load_scale: float, resolution: float,
                    removed: Sequence[Fraction] = ()) -> dict[str, np.ndarray]:
    """PSD [rad² / Hz] of each angle-locked excitation input of the bench.

    Parameters
    ----------
    excitation : mapping
        ``cfg["excitation"]``: ``gearboxes``, ``shaft_orders`` (``order``, ``amplitude``
        [rad]) and ``mesh`` (``stage``, ``amplitude`` [rad], ``harmonics`` weights).
    stages : sequence of mapping
        ``gearbox.stages`` (exact mesh orders).
    inputs : sequence of str
        The bench's excitation inputs, ``te_<g>_mesh<k>`` and ``misalign_<g>_coupling``.
    f_hz : ndarray
        Grid [Hz].
    rotation_hz : (float, float)
        Lowest and highest HSS rotation frequency of the test [Hz].
    load_scale : float
        rms over the test of ``torque_ref / excitation.load_reference`` [1].
    resolution : float
        Analysis resolution [Hz] a line is widened by.
    removed : sequence of Fraction
        Cycle orders of a harmonic removal: the lines it takes off are left out.

    Returns
    -------
    dict
        Input name -> PSD; zero for a gearbox without excitation.
    """
    f = np.asarray(f_hz, dtype=float)
    by_source = excitation_lines(excitation, stages)
    out = {}
    for name in inputs:
        gearbox = name.split("_")[1]
        # misalign_<g>_coupling carries the shaft orders, te_<g>_mesh<k> stage k's mesh
        source = "shaft" if name.startswith("misalign_") else name.rsplit("_", 1)[1]
        psd = np.zeros(f.size)
        if gearbox in excitation["gearboxes"]:
            for order, amplitude in by_source.get(source, []):
                if amplitude > 0 and not whole_multiple(order, removed):
                    psd = psd + line_psd(f, float(order) * rotation_hz[0],
                                         float(order) * rotation_hz[1],
                                         amplitude * load_scale, resolution)
        out[name] = psd
    return out


def sensor_psds(noise: Mapping[str, Any], kinds: Mapping[str, str], fs: float,
                f_hz: np.ndarray) -> dict[str, np.ndarray]:
    """Measurement noise PSD of each recorded signal.

    Parameters
    ----------
    noise : mapping
        ``noise``: ``sensor`` (rms per kind, e.g. ``speed`` [rad/s], ``torque`` [N·m],
        white at ``fs``) and optionally ``encoder.counts_per_rev`` (speeds differenced
        from a quantised angle, added to the speed signals).
    kinds : mapping
        Signal name -> sensor kind (``"speed"`` or ``"torque"``).
    fs : float
        Sample rate of the records [Hz].
    f_hz : ndarray
        Grid [Hz].

    Returns
    -------
    dict
        Signal name -> PSD [unit² / Hz].
    """
    sensor = noise.get("sensor", {})
    encoder = noise.get("encoder") or {}
    out = {}
    for name, kind in kinds.items():
        psd = white_psd(float(sensor.get(kind, 0.0)), fs, f_hz)
        if kind == "speed" and encoder.get("counts_per_rev"):
            psd = psd + quantised_speed_psd(f_hz, float(encoder["counts_per_rev"]), fs)
        out[name] = psd
    return out


def reference_psd(x: np.ndarray, fs: float, f_hz: np.ndarray,
                  resolution: float = 1.0) -> np.ndarray:
    """One-sided PSD of a set-point signal [unit² / Hz] on the grid (module docstring).

    Parameters
    ----------
    x : ndarray
        The set-point samples (its mean is removed per segment).
    fs : float
        Sample rate [Hz].
    f_hz : ndarray
        Grid [Hz].
    resolution : float
        Segment length ``1 / resolution`` seconds (at most the record).
    """
    x = np.asarray(x, dtype=float)
    nper = min(x.size, int(round(fs / resolution)))
    f, p = welch(x, fs=fs, window="hann", nperseg=nper, noverlap=3 * nper // 4,
                 detrend="constant", scaling="density")
    return np.interp(np.asarray(f_hz, dtype=float), f, p, right=0.0)
