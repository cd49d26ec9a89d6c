"""Stabilization diagram of the subspace methods on chains with known modes.

The truth is ``scipy.linalg.eig`` of each chain's continuous state matrix
(tests/sysid/torsional_chain.py); records are seeded, with measurement noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.errors import ConfigError
from gbpipe.sysid import held_modes, lowest_order, moesp, pbsid, stabilization_diagram
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
