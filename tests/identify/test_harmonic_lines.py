"""Order lines are not modes: shaft speed range from pulses, bands, labels (closed forms)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
import xarray as xr

from gbpipe.errors import ConfigError, DataError
from gbpipe.identify.harmonic_lines import (
    harmonic_bands,
    label_poles,
    record_harmonic_bands,
    reference_angle,
    shaft_frequency_range,
)
from gbpipe.measured import parse


def sweep_pulses(f0: float, f1: float, duration: float, ppr: int, spacing: np.ndarray
                 ) -> np.ndarray:
    """Pulse times of a shaft whose frequency rises linearly from f0 to f1 [Hz]: the
    closed-form inverse of theta(t) = 2 pi (f0 t + a t^2 / 2), teeth misplaced by
    ``spacing`` [share of a pitch]."""
    a = (f1 - f0) / duration
    revs = f0 * duration + a * duration ** 2 / 2
    n = np.arange(int(revs * ppr))
    r = (n + spacing[n % ppr]) / ppr  # revolutions at each pulse
    return (-f0 + np.sqrt(f0 ** 2 + 2 * a * r)) / a


@pytest.mark.parametrize(("f0", "f1", "ppr"), [(10.0, 10.4, 1), (5.0, 25.0, 60),
                                               (30.0, 29.0, 4)])
def test_speed_range_from_pulses_is_the_segment_mean_in_whole_revolutions(f0, f1, ppr):
    rng = np.random.default_rng(1)
    # 1.5 % of a pitch per tooth: a per-interval speed would be off by up to ~3 %
    spacing = 0.015 * rng.standard_normal(ppr) if ppr > 1 else np.zeros(1)
    duration, segment = 20.0, 2.0
    if f1 < f0:  # a run-down: the time-reversed run-up's pulses
        p = sweep_pulses(f1, f0, duration, ppr, spacing)
        p = np.sort(duration - p)
    else:
        p = sweep_pulses(f0, f1, duration, ppr, spacing)
    lo, hi = shaft_frequency_range(p, ppr, segment)
    f_min, f_max = min(f0, f1), max(f0, f1)
    # a linear sweep's mean frequency over a window is its frequency at the window's
    # middle; each window spans the segment up to one revolution more (whole revolutions,
    # which cancel the tooth spacing), and the train stops within one revolution of the
    # end: the slowest window's middle lies half a segment into the slow end, plus at
    # most one revolution, the fastest's as far from the fast end, plus at most two
    # (a tooth's misplacement shifts a window's ends by up to its share of a pitch, which
    # moves the middle's frequency by a times that time: the first pulse may even come
    # before t = 0)
    a, rev = abs(f1 - f0) / duration, 1.0 / f_min
    tooth = a * np.max(np.abs(spacing)) / (ppr * f_min) + 1e-9
    assert f_min + a * segment / 2 - tooth <= lo <= f_min + a * (segment / 2 + rev) + tooth
    assert f_max - a * (segment / 2 + 2 * rev) - tooth <= hi <= f_max - a * segment / 2 + tooth


def test_speed_range_from_pulses_takes_whole_revolutions_of_a_misplaced_wheel():
    # a steady 12.5 Hz shaft, 4 teeth misplaced by up to 8 % of a pitch (within the
    # pulse check's tolerance): windows of whole revolutions hold the speed exactly,
    # windows of a pulse count would be off by up to 8e-4
    f0, ppr = 12.5, 4
    spacing = np.array([0.0, 0.08, -0.06, 0.04])
    n = np.arange(10 * 60 * ppr)
    p = 0.01 + (n + spacing[n % ppr]) / ppr / f0
    lo, hi = shaft_frequency_range(p, ppr, 2.0)
    assert lo == pytest.approx(f0, rel=1e-12) and hi == pytest.approx(f0, rel=1e-12)


def test_pulses_shorter_than_a_segment_are_refused():
    p = 0.05 + np.arange(19) / 10.0  # 10 Hz, 18 revolutions in 1.8 s
    assert shaft_frequency_range(p, 1, 1.0)[0] == pytest.approx(10.0)
    with pytest.raises(DataError, match="one Welch segment"):
        shaft_frequency_range(p, 1, 2.0)


def test_a_vibrating_shaft_keeps_its_order_lines_in_a_narrow_band():
    # theta(t) = 2 pi f0 t + A sin(2 pi fm t): a torsional vibration whose speed swing,
    # A fm = 15 % of f0, a per-revolution speed follows; the order-k line of a Welch
    # estimate stays at k f0, with sidebands at k f0 +- n fm of power J_n(k A)^2 (the
    # carrier J_0^2 is the strongest while k A < 1.43; 0.82 here), and the mean over a
    # segment T moves by A / (pi T) at most
    f0, fm, amp, fs, duration, segment, k = 20.0, 7.3, 0.15 * 20.0 / 7.3, 1000.0, 20.0, 2.0, 2
    t = np.arange(int(duration * 50 * fs)) / (50 * fs)
    theta = 2 * np.pi * f0 * t + amp * np.sin(2 * np.pi * fm * t)
    p = np.interp(2 * np.pi * np.arange(1, int(theta[-1] / (2 * np.pi))), theta, t)
    lo, hi = shaft_frequency_range(p, 1, segment)
    bound = amp / (np.pi * segment)
    assert f0 - bound - 1e-6 <= lo <= hi <= f0 + bound + 1e-6
    per_rev = 1.0 / np.diff(p)
    assert per_rev.max() - per_rev.min() > 10 * (hi - lo)  # what the bands used to take
    # the line of order k in the Welch estimate of one segment's resolution lies in the
    # band (k lo, k hi) widened by one frequency line
    ts = np.arange(int(duration * fs)) / fs
    x = np.cos(k * (2 * np.pi * f0 * ts + amp * np.sin(2 * np.pi * fm * ts)))
    f, pxx = scipy.signal.welch(x, fs, nperseg=int(segment * fs))
    b = harmonic_bands((lo, hi), [float(k)], 1.0 / segment, 1)
    peak = f[np.argmax(pxx)]
    assert b.inside(peak)[b.order == k].all()
    # its first sidebands (J_1(k A)^2 / J_0^2 = 0.20 of the carrier's power) lie outside
    # every band: left to the PDF and drift tests, as any peak off a line
    assert pxx[np.argmin(np.abs(f - (k * f0 + fm)))] > 0.1 * pxx.max()
    assert not b.inside([k * f0 - fm, k * f0 + fm]).any()


def test_bands_closed_form_and_labels_at_the_edges():
    shaft, res = (10.0, 10.4), 0.5
    b = harmonic_bands(shaft, [23.0, 2.0], res, n_harmonics=3)
    # orders 1..3 always, 23 from the list, 2 once
    np.testing.assert_array_equal(b.order, [1.0, 2.0, 3.0, 23.0])
    np.testing.assert_allclose(b.low_hz, np.array([1, 2, 3, 23]) * 10.0 - res)
    np.testing.assert_allclose(b.high_hz, np.array([1, 2, 3, 23]) * 10.4 + res)
    f = np.array([23 * 10.4 + 0.9 * res, 23 * 10.4 + 1.1 * res, 230.0 - 0.4, 25.0, 31.0,
                  3 * 10.0 - 1.1 * res])
    assert label_poles(f, b).tolist() == ["harmonic", "mode", "harmonic", "mode",
                                          "harmonic", "mode"]
    # f_max drops the bands that start above it
    assert harmonic_bands(shaft, [23.0], res, 3, f_max=100.0).order.tolist() == [1, 2, 3]


def test_record_without_tacho_and_bad_orders():
    rec = xr.Dataset({"x": ("time", np.zeros(10))})
    assert record_harmonic_bands(rec, [], 0.5, 3).order.size == 0
    with pytest.raises(DataError, match="no tachometer"):
        record_harmonic_bands(rec, [23.0], 0.5, 3)
    with pytest.raises(ConfigError, match="positive"):
        harmonic_bands((10.0, 11.0), [-2.0], 0.5, 3)
    with pytest.raises(ConfigError, match="resolution"):
        harmonic_bands((10.0, 11.0), [2.0], 0.0, 3)


def test_record_bands_from_its_pulse_train():
    p = sweep_pulses(12.0, 12.6, 10.0, 2, np.zeros(2))
    rec = xr.Dataset({"pulse_time": ("pulse", p)}, attrs={"pulses_per_rev": 2})
    b = record_harmonic_bands(rec, [], 0.25, 2)
    # the means over the 4 s segment (1 / resolution) of the 12 -> 12.6 Hz sweep: its
    # frequencies half a segment from either end, within a revolution's change
    assert b.shaft_hz[0] == pytest.approx(12.12, abs=0.01)
    assert b.shaft_hz[1] == pytest.approx(12.48, abs=0.01)
    assert label_poles([25.1, 25.4], b).tolist() == ["harmonic", "mode"]


def test_measured_orders_key():
    spec = {"files": {"a": {"path": "x.csv", "time": "t"}}, "sample_rate": 100.0,
            "signals": {"x": {"file": "a", "channel": "c"}}}
    assert parse(spec).orders == ()
    assert parse(dict(spec, orders=[23, 46.5])).orders == (23.0, 46.5)
    for bad in ([0], [float("inf")], "23", [True]):
        with pytest.raises(ConfigError, match="measured.record.orders"):
            parse(dict(spec, orders=bad))


def test_record_bands_from_a_speed_signal():
    # no tacho: a speed signal of a shaft at 3x the reference, steady at 3 x 8 Hz
    fs = 200.0
    t = np.arange(int(20 * fs)) / fs
    rec = xr.Dataset({"w": ("time", np.full(t.size, 3 * 2 * np.pi * 8.0), {"units": "rad/s"}),
                      "x": ("time", np.zeros(t.size), {"units": "N m"})},
                     attrs={"sample_rate": fs})
    b = record_harmonic_bands(rec, [5.0], 0.5, 2, speeds={"w": 3.0})
    assert b.shaft_hz == pytest.approx((8.0, 8.0))
    assert b.order.tolist() == [1.0, 2.0, 5.0] and "w" in b.source
    assert b.low_hz.tolist() == pytest.approx([7.5, 15.5, 39.5])
    with pytest.raises(DataError, match="must be a speed"):
        record_harmonic_bands(rec, [5.0], 0.5, 2, speeds={"x": 1.0})


def test_reference_angle_from_pulses_and_from_a_speed_signal():
    # theta(t) = 2 pi (f0 t + a t^2 / 2) in closed form; the pulses (2 per rev) place it
    # from the first pulse on, a speed signal of a shaft at 3x the reference from the
    # record's start; neither is known outside its data (NaN), and a record with neither
    # has none
    f0, f1, duration, fs = 12.0, 12.6, 10.0, 500.0
    a = (f1 - f0) / duration
    t = np.arange(int(duration * fs)) / fs
    theta = 2 * np.pi * (f0 * t + a * t ** 2 / 2)
    p = sweep_pulses(f0, f1, duration, 2, np.zeros(2))
    rec = xr.Dataset({"pulse_time": ("pulse", p)}, coords={"time": t},
                     attrs={"pulses_per_rev": 2})
    got = reference_angle(rec, t)
    inside = (t >= p[0]) & (t <= p[-1])
    assert np.all(np.isnan(got[~inside]))
    # the pulse at theta = 0 is the first: got is theta shifted by theta(p[0]) = 0
    assert np.max(np.abs(got[inside] - theta[inside])) < 1e-4
    w = 3 * np.gradient(theta, t, edge_order=2)
    rec = xr.Dataset({"w": ("time", w, {"units": "rad/s"})}, coords={"time": t},
                     attrs={"sample_rate": fs})
    got = reference_angle(rec, t[10:-10] + 0.5 / fs, speeds={"w": 3.0})
    assert np.max(np.abs(got - (theta[10:-10] + np.pi * (f0 + a * t[10:-10]) / fs))) < 1e-4
    assert np.isnan(reference_angle(rec, np.array([t[-1] + 1.0]), speeds={"w": 3.0})[0])
    assert reference_angle(rec, t) is None


def test_shaft_order_key():
    spec = {"files": {"a": {"path": "x.csv", "time": "t"}}, "sample_rate": 100.0,
            "signals": {"w": {"file": "a", "channel": "c", "unit": "rpm",
                              "shaft_order": 2},
                        "x": {"file": "a", "channel": "d"}}}
    assert parse(spec).speeds == {"w": 2.0}
    for bad in (0, -1.0, "2", True):
        s = {**spec, "signals": {"w": {**spec["signals"]["w"], "shaft_order": bad}}}
        with pytest.raises(ConfigError, match="shaft_order"):
            parse(s)
    s = {**spec, "signals": {"t": {"file": "a", "channel": "c", "quantity": "tacho",
                                   "pulses_per_rev": 1, "shaft_order": 1}}}
    with pytest.raises(ConfigError, match="not a shaft speed"):
        parse(s)
