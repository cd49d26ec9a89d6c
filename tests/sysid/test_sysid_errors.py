"""Bad input to the subspace methods gives a clear error before any computation."""

import numpy as np
import pytest

from gbpipe.errors import ConfigError, DataError
from gbpipe.sysid import moesp, n4sid, pbsid


def call(method, u, y, order=2, **kw):
    if method == "pbsid":
        kw.setdefault("past", 8)
        return pbsid(u, y, order, **kw)
    kw.setdefault("horizon", 8)
    return (moesp if method == "moesp" else n4sid)(u, y, order, **kw)


METHODS = ["pbsid", "moesp", "n4sid"]


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    u = rng.standard_normal(500)
    y = np.convolve(u, [0.0, 1.0, 0.5, 0.2])[:500] + 0.01 * rng.standard_normal(500)
    return u, y


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("which", ["u", "y"])
def test_non_finite_samples(method, bad, which, data):
    u, y = (a.copy() for a in data)
    (u if which == "u" else y)[123] = bad
    with pytest.raises(DataError, match=rf"{which} at sample 123: contains NaN or inf"):
        call(method, u, y)


@pytest.mark.parametrize("method", METHODS)
def test_mismatched_lengths(method, data):
    u, y = data
    with pytest.raises(DataError, match="same number of samples.*u: 500, y: 499"):
        call(method, u, y[:-1])


@pytest.mark.parametrize("method", METHODS)
def test_record_too_short(method, data):
    u, y = data
    with pytest.raises(DataError, match="record too short: 20 samples"):
        call(method, u[:20], y[:20])


@pytest.mark.parametrize("method", METHODS)
def test_order_larger_than_windows_allow(method, data):
    u, y = data
    with pytest.raises(ConfigError, match="order=40 is larger than the windows allow"):
        call(method, u, y, order=40)


@pytest.mark.parametrize("method", METHODS)
def test_past_shorter_than_future(method, data):
    u, y = data
    kw = {"past": 4, "future": 8} if method == "pbsid" else {"past": 4, "horizon": 8}
    with pytest.raises(ConfigError, match=r"past \(4\) must be >= "):
        call(method, u, y, **kw)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    ("order", "exc", "msg"),
    [("best", ConfigError, "positive integer or 'auto'"), (0, ConfigError, "order must be >= 1"),
     (2.5, TypeError, "positive integer or 'auto'")],
)
def test_bad_order_value(method, order, exc, msg, data):
    u, y = data
    with pytest.raises(exc, match=msg):
        call(method, u, y, order=order)


@pytest.mark.parametrize("method", METHODS)
def test_zero_channel_and_bad_shape_and_dt(method, data):
    u, y = data
    with pytest.raises(DataError, match="u channel 1 is identically zero"):
        call(method, np.column_stack([u, np.zeros_like(u)]), y)
    with pytest.raises(DataError, match=r"shape \(samples,\) or \(samples, channels\)"):
        call(method, u.reshape(50, 5, 2), y)
    with pytest.raises(ConfigError, match="dt must be a positive"):
        call(method, u, y, dt=-1.0)
    with pytest.raises(TypeError, match="must be real-valued"):
        call(method, u + 1j, y)


def test_model_helpers_reject_wrong_shapes(data):
    u, y = data
    model = pbsid(u, y, 3, past=8)
    with pytest.raises(DataError, match="u has 2 channels but the model has 1 inputs"):
        model.simulate(np.ones((10, 2)))
    with pytest.raises(DataError, match=r"y must have shape \(500, 1\)"):
        model.fit(u, y[:-1])
    with pytest.raises(DataError, match="freq_hz at sample 1: contains NaN"):
        model.frf([1.0, np.nan])
