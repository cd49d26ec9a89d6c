"""gbpipe.lti.lsim within 3x the float64 round-off floor on non-normal systems.

The floor is the error of the plain float64 recursion (scipy.signal.dlsim) on the same
ZOH matrices, both measured against the extended-precision recursion of lti_systems.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from lti_systems import DT, integrators, reference_zoh, relative_error, transient_growth

from gbpipe.lti import NamedSS, lsim
from gbpipe.lti.exact_powers import exact_krylov, exact_power

N_SAMPLES = 8000


def _zoh(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n, m = b.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = a * DT, b * DT
    e = scipy.linalg.expm(big)
    return e[:n, :n], e[:n, n:]


@pytest.mark.parametrize("system", [
    transient_growth(2e2, seed=1),   # mild growth, just below the switch: fast path
    transient_growth(1e5, seed=2),   # eigenvector condition 1e5, |lambda| = 0.9995
    transient_growth(5e5, seed=0),   # the 12-state cond-5e5 case
    transient_growth(1e6, seed=2),   # the worst of the lead's table (306x before)
    integrators(),                   # triple integrator (Jordan block at 1) + a mode
], ids=["growth2e2", "growth1e5", "growth5e5", "growth1e6", "integrators"])
def test_error_within_three_times_float64_floor(system):
    a, b, c, d = system
    ad, bd = _zoh(a, b)
    assert np.abs(np.linalg.eigvals(ad)).max() > 0.999  # lightly damped or integrating
    rng = np.random.default_rng(35)
    u = rng.standard_normal((N_SAMPLES, b.shape[1]))
    x0 = rng.standard_normal(a.shape[0])
    ref = reference_zoh(a, b, c, d, u, DT, x0)
    _, y64, _ = scipy.signal.dlsim((ad, bd, c, d, DT), u, x0=x0)
    y, _ = lsim(NamedSS(a, b, c, d, [], [], []), u, DT, x0)
    assert relative_error(y, ref) <= 3.0 * relative_error(y64, ref)


def _fraction_product(x: list[list[Fraction]], y: list[list[Fraction]]) -> list[list[Fraction]]:
    return [[sum(x[i][k] * y[k][j] for k in range(len(y))) for j in range(len(y[0]))]
            for i in range(len(x))]


def test_exact_powers_equal_rational_arithmetic():
    """a^12 and a^k b of a strongly non-normal matrix against exact fractions."""
    rng = np.random.default_rng(3)
    q1, q2 = (np.linalg.qr(rng.standard_normal((4, 4)))[0] for _ in range(2))
    v = q1 @ np.diag([1.0, 1e-2, 1e-4, 1e-6]) @ q2  # eigenvector condition 1e6
    a = v @ np.diag([0.999, 0.998, -0.997, 0.5]) @ np.linalg.inv(v)
    b = rng.standard_normal((4, 2))
    exact = [[Fraction(x) for x in row] for row in a]
    krylov = [[[Fraction(x) for x in row] for row in b]]
    p = [[Fraction(int(i == j)) for j in range(4)] for i in range(4)]
    for _ in range(12):
        p = _fraction_product(exact, p)
        krylov.append(_fraction_product(exact, krylov[-1]))
    ref = np.array([[float(x) for x in row] for row in p])
    ref_krylov = np.array([[[float(x) for x in row] for row in term] for term in krylov])
    # long double truncation is 2^-63 relative to each entry; the float64 view adds 2^-53
    np.testing.assert_allclose(exact_power(a, 12).astype(float), ref, rtol=2.3e-16, atol=0)
    np.testing.assert_allclose(exact_krylov(a, b, 12).astype(float), ref_krylov,
                               rtol=2.3e-16, atol=0)
    # the float64 chain loses most digits here: the exactness is what the test shows
    chain = np.linalg.matrix_power(a, 12)
    assert np.abs(chain - ref).max() > 1e3 * np.finfo(float).eps * np.abs(ref).max()


def test_exact_krylov_keeps_every_decayed_term_exact():
    """b, a b, .., a^100 b of a stable non-normal matrix against exact fractions, each term
    to its own size: the doubling's products hold terms from 1 down to about 1e-100 side
    by side (the lifted matrices of a damped system, e.g. a Kalman predictor, whose block
    is up to 256 samples), and a truncation relative to the block's largest term left the
    small ones with no correct digit."""
    rng = np.random.default_rng(11)
    q1, q2 = (np.linalg.qr(rng.standard_normal((4, 4)))[0] for _ in range(2))
    v = q1 @ np.diag([1.0, 1e-1, 1e-2, 1e-3]) @ q2  # eigenvector condition 1e3
    a = v @ np.diag([0.1, -0.08, 0.05, 0.02]) @ np.linalg.inv(v)
    b = rng.standard_normal((4, 2))
    exact = [[Fraction(x) for x in row] for row in a]
    krylov = [[[Fraction(x) for x in row] for row in b]]
    for _ in range(100):
        krylov.append(_fraction_product(exact, krylov[-1]))
    ref = np.array([[[float(x) for x in row] for row in term] for term in krylov])
    got = exact_krylov(a, b, 100).astype(float)
    size = np.abs(ref).max(axis=(1, 2))
    assert size[-1] < 1e-90 * size[0]   # the terms span 90 decades
    err = np.abs(got - ref).max(axis=(1, 2)) / size
    # long double truncation 2^-63 of each entry, the float64 view 2^-53
    assert err.max() <= 2.3e-16
