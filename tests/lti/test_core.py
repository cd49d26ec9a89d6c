"""gbpipe.lti: FRF, fit metric, modes, the NamedSS type and the python-control boundary,
each against an independent computation."""

from __future__ import annotations

import subprocess
import sys

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from lti_systems import ill_conditioned

from gbpipe.lti import NamedSS, fit_percent, frf, modes, pad
from gbpipe.lti.control_io import from_control, to_control


def _oscillator(f_hz: float, zeta: float) -> np.ndarray:
    w = 2 * np.pi * f_hz
    return np.array([[0.0, 1.0], [-w * w, -2 * zeta * w]])


def _system(seed: int = 4) -> NamedSS:
    a, b, c, d = ill_conditioned(1e3, seed=seed)
    return NamedSS(a, b, c, d, [f"x{i}" for i in range(a.shape[0])], ["u0", "u1"],
                   ["y0", "y1", "y2"], {"u0": "N m", "u1": "N m", "y0": "rad/s"})


def test_frf_continuous_matches_scipy_freqresp():
    ss = _system()
    f = np.geomspace(1.0, 500.0, 300)
    g = frf(ss, f)
    assert g.shape == (300, 3, 2)
    for j in range(2):
        num, den = scipy.signal.ss2tf(ss.A, ss.B, ss.C, ss.D, input=j)
        for i in range(3):
            _, h = scipy.signal.freqs(num[i], den, worN=2 * np.pi * f)
            np.testing.assert_allclose(g[:, i, j], h, rtol=1e-6)


def test_frf_discrete_matches_control():
    ss = _system()
    a, b, *_ = scipy.signal.cont2discrete((ss.A, ss.B, ss.C, ss.D), 1e-3)
    sd = NamedSS(a, b, ss.C, ss.D, ss.states, ss.inputs, ss.outputs, dt=1e-3)
    f = np.linspace(1.0, 450.0, 200)
    ref = control.frequency_response(to_control(sd), 2 * np.pi * f).frdata  # (p, m, n_f)
    np.testing.assert_allclose(frf(sd, f), np.moveaxis(ref, -1, 0), rtol=1e-9)
    # first-order filter by hand: G(z) = c b / (z - a) + d, z = exp(j 2 pi f dt)
    z = np.exp(2j * np.pi * f * 0.01)
    first = NamedSS(np.array([[0.5]]), np.array([[2.0]]), np.array([[3.0]]),
                    np.array([[0.25]]), ["x"], ["u"], ["y"], dt=0.01)
    np.testing.assert_allclose(frf(first, f)[:, 0, 0], 6.0 / (z - 0.5) + 0.25, rtol=1e-13)


def test_fit_percent_known_values():
    rng = np.random.default_rng(0)
    y = rng.standard_normal((1000, 2)) + 3.0
    np.testing.assert_allclose(fit_percent(y, y), [100.0, 100.0])
    np.testing.assert_allclose(fit_percent(y, np.broadcast_to(y.mean(axis=0), y.shape)),
                               [0.0, 0.0], atol=1e-12)
    # half the deviation from the mean left: fit 50 %
    y_half = y.mean(axis=0) + 0.5 * (y - y.mean(axis=0))
    np.testing.assert_allclose(fit_percent(y, y_half), [50.0, 50.0])
    assert fit_percent(y[:, 0], y[:, 0]).shape == (1,)
    bad = y.copy()
    bad[3, 1] = np.nan
    assert fit_percent(y, bad)[1] == -np.inf
    assert fit_percent(np.ones((10, 1)), np.ones((10, 1)))[0] == -np.inf  # constant y


def test_modes_continuous_and_discrete():
    a = scipy.linalg.block_diag(_oscillator(12.0, 0.02), _oscillator(3.0, 0.3),
                                [[0.0]], [[-50.0]])   # + an integrator and a real pole
    f, z = modes(a)
    np.testing.assert_allclose(f, [3.0, 12.0], rtol=1e-12)
    np.testing.assert_allclose(z, [0.3, 0.02], rtol=1e-10)
    dt = 1e-3
    fd, zd = modes(scipy.linalg.expm(a * dt), dt)
    np.testing.assert_allclose(fd, f, rtol=1e-9)
    np.testing.assert_allclose(zd, z, rtol=1e-9)
    # a free-free chain's double eigenvalue at 0 is not a mode
    assert modes(np.array([[0.0, 1.0], [0.0, 0.0]]))[0].size == 0


def test_named_ss_select_index_and_poles():
    ss = _system()
    sub = ss.select(["u1"], ["y2", "y0"])
    np.testing.assert_array_equal(sub.B, ss.B[:, [1]])
    np.testing.assert_array_equal(sub.C, ss.C[[2, 0]])
    np.testing.assert_array_equal(sub.D, ss.D[np.ix_([2, 0], [1])])
    assert sub.inputs == ["u1"] and sub.outputs == ["y2", "y0"] and sub.dt is None
    sub.units["extra"] = "1"
    assert "extra" not in ss.units        # a selection does not alias the parent's dict
    assert ss.index("output", "y1") == 1
    with pytest.raises(ValueError, match="unknown input 'nope'.*u0, u1"):
        ss.index("input", "nope")
    np.testing.assert_allclose(np.sort_complex(ss.poles()),
                               np.sort_complex(np.linalg.eigvals(ss.A)))


def test_control_round_trip_keeps_names_and_time_base():
    ss = _system()
    sys_c = to_control(ss, name="plant")
    assert sys_c.input_labels == ss.inputs and sys_c.output_labels == ss.outputs
    assert sys_c.name == "plant" and sys_c.isctime()
    back = from_control(sys_c)
    for k in "ABCD":
        np.testing.assert_array_equal(getattr(back, k), getattr(ss, k))
    assert back.states == ss.states and back.dt is None
    disc = from_control(control.ss(ss.A * 1e-4, ss.B, ss.C, ss.D, 0.01))
    assert disc.dt == 0.01
    assert from_control(control.tf([1.0], [1.0, 2.0])).A.shape == (1, 1)


def test_lti_does_not_import_control():
    """python-control (about 3 s) is imported by gbpipe.lti.control_io only."""
    code = "import sys, gbpipe.lti, gbpipe.model; print('control' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


def test_pad_puts_a_smaller_model_in_the_corner_of_nan():
    g = np.arange(6).reshape(1, 2, 3) * (1 + 1j)          # a complex FRF keeps its phase
    out = pad(g, (1, 3, 4))
    assert out.dtype == complex and out.shape == (1, 3, 4)
    np.testing.assert_array_equal(out[:, :2, :3], g)
    assert np.isnan(out[:, 2, :]).all() and np.isnan(out[:, :, 3]).all()
    ints = pad(np.array([1, 2]), (3,))                     # integers become float
    assert ints.dtype == float and ints[:2].tolist() == [1.0, 2.0] and np.isnan(ints[2])

