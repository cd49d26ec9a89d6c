"""Poly-reference LSCF on FRFs of chains with known modes (tests/sysid/torsional_chain.py).

Truth: ``scipy.linalg.eig`` of the continuous state matrix; the FRF is that of its
zero-order-hold discretisation, whose poles are ``exp(s dt)`` exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.errors import ConfigError, DataError
from gbpipe.sysid import lscf_stabilization
from gbpipe.sysid.lscf import lscf_poles
from tests.sysid.torsional_chain import assert_true_modes, chain, discrete


def _frf(ch, n_lines=2000):
    ad, bd, cd, _ = discrete(ch)
    f = np.linspace(0.0, 0.5 / ch.dt, n_lines)
    z = np.exp(2j * np.pi * f * ch.dt)
    eye = np.eye(ad.shape[0])
    return f, np.array([cd @ np.linalg.solve(zk * eye - ad, bd) for zk in z])


def _true_poles(ch):
    return -ch.damping * 2 * np.pi * ch.frequency_hz + 1j * 2 * np.pi * ch.frequency_hz \
        * np.sqrt(1 - ch.damping ** 2)


@pytest.mark.parametrize(("seed", "inputs"), [(7, (0,)), (8, (0,)), (1, (0, 5)), (6, (0, 5))])
def test_exact_frf_gives_the_true_poles(seed, inputs):
    ch = chain(seed, inputs=inputs)
    # Every mode visible (a mode of nearly no residue is a near pole-zero cancellation,
    # which no fit of the FRF can place).
    assert ch.peak.min() > 0.01
    f, h = _frf(ch)
    n = 12 // len(inputs)  # 12 states: polynomial order x inputs
    z, part = lscf_poles(f, h, [n - 1, n], ch.dt)[1]
    s = np.log(z) / ch.dt
    s = s[s.imag > 0]
    for st in _true_poles(ch):
        assert np.min(np.abs(s - st)) / abs(st) < 1e-6
    assert part.shape == (len(inputs), 12)


# The orders reach about twice the order where the last mode appears (a mode must span
# half the orders of the best-established one); one input needs more orders than two.
@pytest.mark.parametrize(("seed", "inputs", "top"), [(1, (0, 5), 40), (6, (0, 5), 60),
                                                     (8, (0,), 80)])
def test_noisy_frf_clusters_are_the_true_modes_at_the_least_order(seed, inputs, top):
    ch = chain(seed, inputs=inputs)
    f, h = _frf(ch)
    rng = np.random.default_rng(seed)
    level = 0.01 * np.sqrt(np.mean(np.abs(h) ** 2, axis=0))  # 1 % of each element's RMS
    h = h + level * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    st = lscf_stabilization(f, h, range(2, top + 1, 2), ch.dt)
    assert_true_modes(st, ch)
    assert st.method == "lscf" and st.clusters[0].shape.shape == (len(inputs),)


def test_bad_frf_is_refused_before_the_fit():
    ch = chain(1)
    f, h = _frf(ch, 50)
    bad = h.copy()
    bad[7, 0, 0] = np.nan
    with pytest.raises(DataError, match="line 7"):
        lscf_poles(f, bad, [2, 4], ch.dt)
    with pytest.raises(DataError, match="Nyquist"):
        lscf_poles(f * 1.5, h, [2, 4], ch.dt)
    with pytest.raises(DataError, match="weights"):
        lscf_poles(f, h, [2, 4], ch.dt, weights=-np.ones(f.size))
    with pytest.raises(ConfigError) as err:
        lscf_poles(f, h, [2, 60], ch.dt)
    assert err.value.field == "orders"


def test_modes_the_orders_only_begin_to_hold_are_modes_and_noise_is_not():
    """One input and 1 % noise: the three lowest modes stabilise only above order ~50,
    too late to span half the orders of the best mode by 80, but in half the orders that
    can hold them (from where they enter): every mode above 1/20 of the largest peak is
    a cluster within 1 %, and every cluster is a true mode (the noise poles that stay put
    a few orders near the top stay candidates)."""
    ch = chain(18, inputs=(0,))
    f, h = _frf(ch)
    rng = np.random.default_rng(18)
    h = h + 0.01 * np.sqrt(np.mean(np.abs(h) ** 2, axis=0)) * (
        rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    short = lscf_stabilization(f, h, range(2, 81, 2), ch.dt)
    found = np.array([m.frequency_hz for m in short.clusters])
    for f_true in ch.frequency_hz[ch.peak > 0.05]:
        assert np.min(np.abs(found / f_true - 1)) < 0.01
    for fm in found:
        assert np.min(np.abs(ch.frequency_hz / fm - 1)) < 0.01
