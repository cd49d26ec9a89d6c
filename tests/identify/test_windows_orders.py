"""Choices from the data for bench records: the operating point before the first
excitation, a hold-out window on the excitation, pooled repeats, and the order per
pairing from a stabilization result (built by hand here)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.identify.orders import row_order, stabilization_orders
from gbpipe.identify.windows import band_energy, excitation_onset, holdout_window, window_sums

FS = 1000.0
BAND = (5.0, 300.0)


def _bursts(seed: int, n_s: float, bursts: list[tuple[float, float]]) -> np.ndarray:
    """White-noise bursts on a weak floor (-40 dB), plus a slow drift outside the band."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(n_s * FS)) / FS
    x = 0.01 * rng.standard_normal(t.size) + 5.0 * np.sin(2 * np.pi * 0.05 * t)
    for a, b in bursts:
        on = (t >= a) & (t < b)
        x[on] += rng.standard_normal(on.sum())
    return x[:, None]


@pytest.mark.parametrize("seed, bursts", [
    (1, [(5.0, 12.0), (15.0, 22.0), (24.0, 29.0)]),
    (2, [(3.0, 6.0), (20.0, 30.0)]),
    (3, [(8.0, 9.0), (12.0, 13.0), (16.0, 17.0), (25.0, 26.0)]),
])
def test_holdout_lands_on_the_bursts_of_a_record_whose_last_quarter_is_quiet(seed, bursts):
    x = _bursts(seed, 40.0, bursts)  # last quarter (30-40 s) quiet
    e = band_energy(x, FS, BAND)
    hold = holdout_window(e, 0.25, 0.1, FS)
    start, stop = hold.start / FS, hold.stop / FS
    assert stop - start == pytest.approx(10.0)
    # the share of burst samples inside the window, counted independently of the energy
    t = np.arange(x.shape[0]) / FS
    burst = np.zeros(t.size, bool)
    for a, b in bursts:
        burst |= (t >= a) & (t < b)
    inside = burst[hold.start:hold.stop].sum() / burst.sum()
    # its mean band power reaches 0.1 of the record's: it holds >= 0.1 x 0.25 of the band
    # energy, so burst samples too (counted: at least half that share; a sliver of a few
    # tenths of a second, over which the band-pass rings at the burst's edge), and it is
    # not the quiet last quarter
    assert hold.power_share >= 0.025 and inside >= 0.0125 and start < 30.0, (start, inside)
    # the last quarter would have held ~1e-4 of the band power (the -40 dB floor)
    assert e[int(30 * FS):].sum() / e.sum() < 1e-3


def test_holdout_keeps_an_end_with_random_excitation_beside_strong_steps():
    # two short events 18 dB above random excitation everywhere (the measured example's
    # shape): the end holds only 6 % of the band energy but the random excitation at -6 dB
    # of the record's mean, so it is kept and no event is taken out of the fit
    x = _bursts(6, 40.0, [])
    rng = np.random.default_rng(7)
    x += 0.3 * rng.standard_normal(x.shape)
    for a in (5, 20):  # 1 s events at 8x the random excitation's rms
        x[int(a * FS):int((a + 1) * FS)] += 2.4 * rng.standard_normal((int(FS), 1))
    e = band_energy(x, FS, BAND)
    assert e[int(30 * FS):].sum() / e.sum() < 0.1  # the end holds < 10 % of the total...
    hold = holdout_window(e, 0.25, 0.1, FS)
    assert (hold.start, hold.stop) == (30000, 40000)  # ...and is kept


def test_holdout_keeps_the_end_when_it_is_excited_and_the_user_window_wins():
    x = _bursts(4, 40.0, [(0.0, 40.0)])
    hold = holdout_window(band_energy(x, FS, BAND), 0.25, 0.1, FS)
    assert (hold.start, hold.stop) == (30000, 40000)
    user = holdout_window(band_energy(x, FS, BAND), 0.25, 0.1, FS, (12.0, 20.0))
    assert (user.start, user.stop) == (12000, 20000) and "validation" in user.source


@pytest.mark.parametrize("onset", [2.0, 3.5, 7.0])
def test_onset_is_before_the_first_burst_within_one_window(onset):
    x = _bursts(5, 30.0, [(onset, onset + 4.0), (15.0, 25.0)])
    got = excitation_onset(x, FS, BAND, 1.0)
    assert onset - 1.0 <= got <= onset


def _modes(orders: np.ndarray, methods=("pbsid", "lscf"), pairings=("a", "b")) -> xr.Dataset:
    return xr.Dataset({"model_order": (("method", "pairing"), orders)},
                      coords={"method": list(methods), "pairing": list(pairings)})


def test_orders_come_from_the_stabilization_result_with_their_source():
    ds = _modes(np.array([[12.0, 18.0], [10.0, 14.0]]))
    orders, prov = stabilization_orders(ds, "pbsid", ["a", "b"], "run12.nc")
    assert orders == {"a": 12, "b": 18}
    assert prov["b"] == "stabilization: run12.nc model_order[method=pbsid, pairing=b]"
    # a method the diagram lacks: its first row, named
    orders, prov = stabilization_orders(ds, "moesp", ["a"], "run12.nc")
    assert orders == {"a": 12} and "method=pbsid" in prov["a"]
    s = {"order": "stabilization", "max_order": 26}
    assert row_order(s, "a", orders, prov) == (12, prov["a"])
    # no diagram for it: no order (its rows fail), and it says why; no constant of the
    # configured bench (max_order) stands in
    order, why = row_order(s, "c", orders, prov)
    assert order is None and "no stabilization diagram" in why
    assert row_order({"order": 24, "max_order": 26}, "a", None) == (24, "identify.order = 24")


def test_unusable_stabilization_orders_are_refused():
    with pytest.raises(DataError, match="no pairing 'c'"):
        stabilization_orders(_modes(np.array([[12.0, 18.0], [10.0, 14.0]])), "pbsid", ["c"],
                             "run12.nc")


@pytest.mark.parametrize("value", [np.nan, 0.0])
def test_a_pairing_without_a_stable_order_fails_alone(value):
    # a diagram that found nothing for pairing a: a has no order and says why, b goes on
    ds = _modes(np.array([[value, 18.0], [10.0, 14.0]]))
    orders, prov = stabilization_orders(ds, "pbsid", ["a", "b"], "run12.nc")
    assert orders == {"b": 18}
    assert prov["a"].startswith("no model order") and "pairing=a" in prov["a"]
    assert row_order({"order": "stabilization"}, "a", orders, prov) == (None, prov["a"])


def test_measured_record_takes_a_validation_window_and_a_group():
    from gbpipe.errors import ConfigError
    from gbpipe.measured import parse

    base = {"files": {"f": {"path": "x.csv", "time": "t"}}, "sample_rate": 1000.0,
            "signals": {"torque": {"file": "f", "channel": "T"}}}
    spec = parse({**base, "validation": {"start": 12, "end": 20.5}, "group": "test7"}, "r1")
    assert spec.validation == (12.0, 20.5) and spec.group == "test7"
    assert parse(base, "r2").validation is None and parse(base, "r2").group is None
    with pytest.raises(ConfigError, match=r"measured.r3.validation.*start < end"):
        parse({**base, "validation": {"start": 20, "end": 12}}, "r3")
    with pytest.raises(ConfigError, match=r"measured.r4.validation.*needs both"):
        parse({**base, "validation": {"start": 2}}, "r4")


@pytest.mark.parametrize("n", [1, 7, 5000, 20_000])
def test_window_sums_are_numpys_convolution_with_the_window(n):
    # the running-sum form against the direct one (np.convolve, n per sample): every full
    # window, within the running sum's rounding (len / n eps of a window's sum)
    x = np.random.default_rng(n).random(20_000) ** 4
    direct = np.convolve(x, np.ones(n), mode="valid")
    got = window_sums(x, n)
    assert got.shape == direct.shape == (x.size - n + 1,)
    np.testing.assert_allclose(got, direct, rtol=0, atol=1e-12 * direct.max())
