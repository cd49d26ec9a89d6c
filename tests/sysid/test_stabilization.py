"""Stabilization diagram of the subspace methods on chains with known modes.

The truth is ``scipy.linalg.eig`` of each chain's continuous state matrix
(tests/sysid/torsional_chain.py); records are seeded, with measurement noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.errors import ConfigError
from gbpipe.sysid import moesp, pbsid, stabilization_diagram
from tests.sysid.torsional_chain import chain, record

ORDERS = range(2, 41, 2)


def _holds(poles, f_true, tol=0.01):
    """Does an order's pole set have a pole within ``tol`` of every true mode?"""
    f = poles[0]
    return f.size > 0 and bool(np.all(np.min(np.abs(f[None, :] - f_true[:, None]), axis=1)
                                      <= tol * f_true))


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
    f_est = np.array([m.frequency_hz for m in st.clusters])
    z_est = np.array([m.damping for m in st.clusters])
    # Every cluster is a true mode (no noise pole is reported), within 1 % and 20 %...
    near = np.argmin(np.abs(f_est[:, None] / ch.frequency_hz[None, :] - 1), axis=1)
    assert np.unique(near).size == near.size
    np.testing.assert_array_less(np.abs(f_est / ch.frequency_hz[near] - 1), 0.01)
    np.testing.assert_array_less(np.abs(z_est / ch.damping[near] - 1), 0.20)
    # ... and every mode standing well above the noise (peak > 1/20 of the largest) is one.
    assert set(np.flatnonzero(ch.peak > 0.05)) <= set(near)
    # The chosen order holds every found mode; the order before it does not.
    k = list(st.orders).index(st.order)
    assert _holds(st.poles[k], ch.frequency_hz[near])
    assert k == 0 or not _holds(st.poles[k - 1], ch.frequency_hz[near])
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
