"""Persistent excitation: inputs too poor for the requested order are refused, with why."""

import numpy as np
import pytest
import scipy.signal as sig
from sysid_plants import simulate, two_mode_plant

from gbpipe.errors import ExcitationError
from gbpipe.sysid import input_hankel_rank, moesp, n4sid, pbsid
from gbpipe.sysid.checks import prepare
from gbpipe.sysid.hankel import hankel_gram

N = 4000
T = np.arange(N)
METHODS = {
    "pbsid": lambda u, y, n, **kw: pbsid(u, y, n, past=20, **kw),
    "moesp": lambda u, y, n, **kw: moesp(u, y, n, horizon=10, **kw),
    "n4sid": lambda u, y, n, **kw: n4sid(u, y, n, horizon=10, **kw),
}
DEPTH = {"pbsid": "21 (past 20 + the current sample)", "moesp": "20 (past 10 + horizon 10)",
         "n4sid": "20 (past 10 + horizon 10)"}


def response(u):
    """Plant output plus a little white noise, so the output itself is never the problem."""
    y = simulate(*two_mode_plant(), u.reshape(N, -1)[:, :1])
    return y + 0.01 * y.std() * np.random.default_rng(1).standard_normal(y.shape)


def prbs():
    """Maximum-length binary sequence (period 1023), +-1."""
    return np.resize(sig.max_len_seq(10)[0] * 2.0 - 1.0, N)


@pytest.mark.parametrize("method", METHODS)
def test_constant_input_is_refused(method):
    u = np.full(N, 2.5)
    with pytest.raises(ExcitationError) as exc:
        METHODS[method](u, response(u), 4)
    msg = str(exc.value)
    assert msg.startswith("input 0 ('u[0]') is constant")
    assert f"depth {DEPTH[method]} has rank 1 " in msg
    assert "model order 4 needs rank >= 8" in msg  # n + m n = 4 + 4 for one input, no D
    assert "excitation at 2 or more distinct frequencies" in msg


@pytest.mark.parametrize("method", METHODS)
def test_single_sinusoid_supports_order_1_not_4(method):
    u = np.sin(2 * np.pi * 0.05 * T)
    y = response(u)
    with pytest.raises(ExcitationError) as exc:
        METHODS[method](u, y, 4, feedthrough=True)
    msg = str(exc.value)
    assert "has rank 2 over the" in msg and "at most 1 sinusoid." in msg
    assert "model order 4 needs rank >= 9" in msg  # 2 n + 1 with feedthrough
    assert "lower the order to <= 0" not in msg
    # One sinusoid determines the response at one frequency: two numbers, a first-order
    # model without feedthrough (one pole, one gain) and no more.
    assert METHODS[method](u, y, 1).order == 1
    with pytest.raises(ExcitationError, match="lower the order to <= 1"):
        METHODS[method](u, y, 2)


@pytest.mark.parametrize("method", METHODS)
def test_prbs_passes_and_identifies_the_plant(method):
    u = prbs()
    y = response(u)
    model = METHODS[method](u, y, 4)
    assert model.info["input_hankel_rank"] == model.info["input_hankel_depth"]
    poles = np.sort_complex(np.linalg.eigvals(two_mode_plant()[0]))
    np.testing.assert_allclose(np.sort_complex(model.poles), poles, atol=5e-3)


def test_collinear_inputs_are_refused():
    u = np.random.default_rng(2).standard_normal(N)
    with pytest.raises(ExcitationError, match=r"input 0 \('u\[0\]'\) adds only rank 0 to the "
                       r"other input .*nearly linearly dependent"):
        pbsid(np.column_stack([u, -2.0 * u]), response(u), 4, past=20)


def test_auto_order_is_capped_by_the_excitation():
    # Three sinusoids: rank 6, so at most order 3 (2 n <= 6) although the plant has 4.
    u = sum(np.sin(2 * np.pi * f * T + k) for k, f in enumerate((0.03, 0.12, 0.27)))
    model = pbsid(u, response(u), "auto", past=20)
    assert model.info["input_hankel_rank"] == 6
    assert model.order <= 3


@pytest.mark.parametrize("n_lines", [1, 2, 5])
def test_rank_from_gram_equals_rank_of_explicit_hankel(n_lines):
    rng = np.random.default_rng(n_lines)
    freqs = rng.uniform(0.01, 0.45, n_lines)
    u = sum(np.cos(2 * np.pi * f * T + rng.uniform(0, 6)) for f in freqs)
    data = prepare(u, rng.standard_normal(N), min_samples=1, window_desc="")
    depth = 16
    rank = input_hankel_rank(hankel_gram(data.z, depth), 1, depth)
    explicit = np.lib.stride_tricks.sliding_window_view(u, depth)
    assert rank.total == np.linalg.matrix_rank(explicit) == 2 * n_lines
