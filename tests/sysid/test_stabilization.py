"""Stabilization diagram of the subspace methods on chains with known modes.

The truth is ``scipy.linalg.eig`` of each chain's continuous state matrix
(tests/sysid/torsional_chain.py); records are seeded, with measurement noise.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from gbpipe.errors import ConfigError
from gbpipe.sysid import (
    held_modes,
    lowest_order,
    moesp,
    pbsid,
    stabilization_diagram,
)
from gbpipe.sysid.stabilization import stabilize
from tests.sysid.torsional_chain import assert_true_modes, chain, record

ORDERS = range(2, 41, 2)


@pytest.mark.parametrize(("seed", "method", "settings"), [
    (1, "moesp", {"horizon": 25}),
    (2, "n4sid", {"horizon": 25}),
    (3, "moesp", {"horizon": 25}),
    (4, "pbsid", {"past": 150, "future": 25}),
])
def test_clusters_are_the_true_modes_and_the_order_is_the_least_that_holds_them(
        seed, method, settings):
    ch = chain(seed)
    u, y = record(ch, 20000, noise=0.05, seed=100 + seed)
    st = stabilization_diagram(u, y, ch.dt, ORDERS, method, **settings)
    near = assert_true_modes(st, ch)
    assert st.order >= 2 * near.size  # a pair of states per mode
    for m in st.clusters:
        assert 3 <= m.n_orders <= len(ORDERS)
        assert m.frequency_spread_hz < 0.01 * m.frequency_hz


def test_every_order_gives_the_poles_of_the_method_fitted_at_that_order():
    ch = chain(5)
    u, y = record(ch, 5000, noise=0.02, seed=7)
    for method, fit, kw in (("moesp", moesp, {"horizon": 15}),
                            ("pbsid", pbsid, {"past": 30, "future": 15})):
        st = stabilization_diagram(u, y, ch.dt, [8, 12, 16], method, max_damping=1.0, **kw)
        for n, (f, z, _) in zip(st.orders, st.poles, strict=True):
            ev = np.log(fit(u, y, int(n), dt=ch.dt, **kw).poles.astype(complex)) / ch.dt
            ev = ev[(ev.imag > 0) & (ev.real <= 0) & (np.abs(ev) < np.pi / ch.dt)]
            ev = ev[np.argsort(np.abs(ev))]
            np.testing.assert_allclose(f, np.abs(ev) / (2 * np.pi), rtol=1e-8)
            np.testing.assert_allclose(z, -ev.real / np.abs(ev), rtol=1e-6, atol=1e-12)


def test_output_noise_alone_gives_no_mode():
    rng = np.random.default_rng(11)
    u = rng.standard_normal(8000)
    y = rng.standard_normal((8000, 2))  # unrelated to u: nothing to identify
    st = stabilization_diagram(u, y, 1e-3, ORDERS, "moesp", horizon=21)
    assert st.clusters == []
    assert st.order == 0


def test_physically_meaningless_poles_are_dropped():
    ch = chain(6)
    u, y = record(ch, 4000, noise=0.05, seed=3)
    st = stabilization_diagram(u, y, ch.dt, ORDERS, "moesp", horizon=25, max_damping=0.1)
    for f, z, shape in st.poles:
        assert np.all((z >= 0) & (z <= 0.1))
        assert np.all((f > 0) & (f < 0.5 / ch.dt))
        assert shape.shape == (f.size, 3)


@pytest.mark.parametrize(("orders", "kw", "field"), [
    ([4], {}, "orders"),
    ([4, 4, 6], {}, "orders"),
    ([0, 2], {}, "orders"),
    ([2, 4], {"method": "ssi"}, "method"),
    ([2, 4], {"mac_min": 1.5}, "mac_min"),
    ([2, 4], {"frequency_tolerance": 0.0}, "frequency_tolerance"),
    ([2, 400], {"future": 20}, "order"),
])
def test_bad_arguments_name_the_field(orders, kw, field):
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal(2000), rng.standard_normal(2000)
    with pytest.raises(ConfigError) as err:
        stabilization_diagram(u, y, 1e-3, orders, past=20, **kw)
    assert err.value.field == field


def test_a_mode_no_order_holds_does_not_push_the_order_to_the_highest():
    """Another diagram's mode that no order of this one holds (LSCF's mode beside PBSID's
    lines) is left out of this diagram's order, which holds the rest at the lowest order."""
    orders = np.array([2, 4, 6, 8])
    one = np.ones(1)
    poles = [(np.array([30.0]), 0.02 * one, one), (np.array([10.02, 30.0]), 0.02 * one, one),
             (np.array([10.0, 30.01]), 0.02 * one, one), (np.array([10.0, 30.0]), 0.02 * one,
                                                          one)]
    wanted = np.array([10.0, 30.0, 62.0])      # 62 Hz: no order holds it
    held = held_modes(poles, wanted, 0.01)
    assert held.tolist() == [True, True, False]
    assert lowest_order(orders, poles, wanted, 0.01) == 8       # asked for all: the highest
    assert lowest_order(orders, poles, wanted[held], 0.01) == 4


def test_a_mode_only_high_orders_hold_is_kept_and_a_pole_entering_at_the_top_is_not():
    """The cluster size is a share of the orders that can hold the mode. A 120 Hz mode that
    enters at order 30 (a model has room for it from there) and is stable at 10 of its 16
    orders is a mode, though the 50 Hz mode's cluster holds 29: half of the orders that can
    hold it. A 300 Hz pole that enters at order 54, stable at the last 3 orders, has 4
    orders left: fewer than half of the 30 that can hold the 50 Hz mode, too few to tell
    it from noise."""
    orders = np.arange(2, 61, 2)
    poles = []
    for n in orders:
        f, z = [50.0], [0.02]
        if n >= 30:  # damping jumps between orders up to 40: not stable there
            f.append(120.0)
            z.append(0.08 if n < 42 and (n // 2) % 2 else 0.06)
        if n >= 54:
            f.append(300.0)
            z.append(0.03)
        poles.append((np.array(f), np.array(z), np.ones((len(f), 1))))
    st = stabilize(orders, poles, "test")
    assert [m.frequency_hz for m in st.clusters] == [50.0, 120.0]
    assert [m.n_orders for m in st.clusters] == [29, 10]
    assert st.clusters[1].damping == 0.06
    assert [(m.frequency_hz, m.n_orders) for m in st.candidates] == [(300.0, 3)]
    assert st.order == 30  # the lowest order holding both modes


def test_a_heavily_damped_mode_is_found_with_its_frequency_and_damping():
    """Two modes in modal coordinates, 40 Hz at 1 % and 110 Hz at 8 % damping (half-power
    band 17.6 Hz), white torque in, two outputs with 5 % noise: both are clusters, within
    1 % in frequency and 20 % in damping of the truth."""
    dt, f, z = 1e-3, np.array([40.0, 110.0]), np.array([0.01, 0.08])
    w = 2 * np.pi * f
    a = np.zeros((4, 4))
    for k in range(2):
        a[2 * k: 2 * k + 2, 2 * k: 2 * k + 2] = [[0.0, 1.0], [-w[k] ** 2, -2 * z[k] * w[k]]]
    b = np.array([[0.0], [1.0], [0.0], [1.0]])
    c = np.array([[0.0, 1.0, 0.0, 1.0], [0.0, 1.0, 0.0, -1.0]])
    ad, bd, cd, dd, _ = scipy.signal.cont2discrete((a, b, c, np.zeros((2, 1))), dt)
    rng = np.random.default_rng(0)
    u = rng.standard_normal(20000)
    _, y, _ = scipy.signal.dlsim((ad, bd, cd, dd, dt), u)
    y = y + 0.05 * y.std(axis=0) * rng.standard_normal(y.shape)
    st = stabilization_diagram(u, y, dt, ORDERS, "pbsid", past=40, future=20)
    assert len(st.clusters) == 2
    np.testing.assert_allclose([m.frequency_hz for m in st.clusters], f, rtol=0.01)
    np.testing.assert_allclose([m.damping for m in st.clusters], z, rtol=0.2)
