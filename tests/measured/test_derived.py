"""Speed from an encoder angle: exact in the record's band, noise not amplified."""

from __future__ import annotations

import numpy as np
import pytest
from measured_bench import FS, angle_true, line_amplitude, speed_true, write_csv
from scipy.signal import freqz, savgol_coeffs

from gbpipe.measured import read
from gbpipe.measured.derived import BAND, GAIN_TOL, POLYORDER, savgol_window
from gbpipe.measured.timebase import Piece, resample


def test_window_keeps_the_band():
    """The chosen window's derivative gain is within GAIN_TOL of jω up to BAND·Nyquist,
    and the next longer window's is not (it is the longest that passes)."""
    fs_src, fs_rec = 10_000.0, 1000.0
    n = savgol_window(fs_src, fs_rec)
    f = np.linspace(1.0, BAND * fs_rec / 2, 200)

    def worst(m):
        c = savgol_coeffs(m, POLYORDER, deriv=1, delta=1 / fs_src, use="conv")
        _, h = freqz(c, worN=f, fs=fs_src)
        h = h * np.exp(1j * 2 * np.pi * f * (m - 1) / 2 / fs_src)
        return np.max(np.abs(h / (2j * np.pi * f) - 1))

    assert worst(n) <= GAIN_TOL * 1.01 and worst(n + 2) > GAIN_TOL * 0.99
    assert n > 5  # a real smoothing window at 10x oversampling


def _encoder_record(tmp_path, ang, fs_src):
    t = np.arange(ang.size) / fs_src
    write_csv(tmp_path / "e.csv", {"time": t, "enc": ang})
    spec = {"files": {"e": {"path": "e.csv", "time": "time"}}, "sample_rate": 1000.0,
            "signals": {"speed": {"file": "e", "channel": "enc", "unit": "rad",
                                  "quantity": "angle"}}}
    return read(spec, tmp_path)


def test_speed_ripple_in_band_is_exact(tmp_path):
    """A 300 Hz speed ripple (0.6 of the 1 kHz record's Nyquist frequency) keeps its
    amplitude within 0.2 %; differencing after resampling would halve it
    (sin(ωT)/(ωT) = 0.50 at 0.3 fs)."""
    fs_src, f_r, a_r = 10_000.0, 300.0, 0.5
    t = np.arange(40_000) / fs_src
    ang = 30.0 * t - a_r / (2 * np.pi * f_r) * np.cos(2 * np.pi * f_r * t)
    ds = _encoder_record(tmp_path, ang, fs_src)
    tt, w = ds["time"].values[50:-50], ds["speed"].values[50:-50]
    assert line_amplitude(w, tt, f_r) == pytest.approx(a_r, rel=2e-3)
    naive = np.gradient(np.interp(ds["time"].values, t, ang), 1e-3)[50:-50]
    assert line_amplitude(naive, tt, f_r) < 0.6 * a_r


def test_quantised_encoder_noise_not_amplified(tmp_path):
    """A 2^12-count encoder at 10 kHz: the speed noise is no larger than that of a
    central difference at the source rate put through the same anti-aliased resampler
    (the in-band noise is all any undistorted derivative must keep), and unbiased."""
    fs_src = 10_000.0
    t = np.arange(40_000) / fs_src
    q = 2 * np.pi / 2 ** 12
    ang = np.floor(angle_true(t) / q) * q
    ds = _encoder_record(tmp_path, ang, fs_src)
    tt = ds["time"].values
    err_sg = (ds["speed"].values - speed_true(tt))[50:-50]
    grad = resample(Piece(np.gradient(ang, 1 / fs_src), 0.0, 1 / fs_src), tt[0], 1000.0,
                    tt.size)
    err_grad = (grad - speed_true(tt))[50:-50]
    assert np.std(err_sg) <= 1.05 * np.std(err_grad)
    assert abs(np.mean(err_sg)) < 0.01


def test_shaft_stopping_is_not_clipping(tmp_path):
    """An encoder resting at its final angle is a flat top that is not clipping."""
    t = np.arange(4000) / FS
    ang = np.minimum(angle_true(t), angle_true(t[3000]))
    write_csv(tmp_path / "e.csv", {"time": t, "enc": np.degrees(ang)})
    spec = {"files": {"e": {"path": "e.csv", "time": "time"}}, "sample_rate": FS,
            "signals": {"speed": {"file": "e", "channel": "enc", "unit": "deg",
                                  "quantity": "angle"}}}
    ds = read(spec, tmp_path)
    assert np.all(np.abs(ds["speed"].values[3100:]) < 1e-6)
