"""Load spectra against closed forms (the ASTM E1049-85 worked example, a sampled cosine,
a held level) and against an independent rainflow count (the four-point method, written
here) on random signals."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.loads import (
    damage_equivalent_load,
    load_duration,
    rainflow_cycles,
    range_histogram,
)


def four_point(x: np.ndarray) -> dict[float, float]:
    """Range -> count by the four-point method (residue: half cycles of consecutive
    reversals), written independently of the library."""
    d = np.diff(x)
    keep = np.r_[True, d[1:] * d[:-1] < 0, True] & np.r_[True, d != 0]
    rev = list(x[keep])
    # drop repeated points that are no reversal (flat runs)
    stack: list[float] = []
    out: dict[float, float] = {}
    for r in rev:
        stack.append(r)
        while len(stack) >= 4:
            s1, s2, s3, s4 = stack[-4:]
            inner = abs(s2 - s3)
            if inner <= abs(s1 - s2) and inner <= abs(s3 - s4):
                out[inner] = out.get(inner, 0.0) + 1.0
                del stack[-3:-1]
            else:
                break
    for a, b in zip(stack[:-1], stack[1:], strict=True):
        out[abs(a - b)] = out.get(abs(a - b), 0.0) + 0.5
    return out


def test_astm_example_counts():
    """ASTM E1049-85, Fig. 6 / Table 4 (rainflow counting of the example history)."""
    x = np.array([-2, 1, -3, 5, -1, 3, -4, 4, -2], dtype=float)
    c = rainflow_cycles(x)
    got = {}
    for r, n in zip(c.range, c.count, strict=True):
        got[r] = got.get(r, 0.0) + n
    assert got == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}


@pytest.mark.parametrize("m", [3.0, 4.0, 10.0])
def test_cosine_del_closed_form(m):
    """P periods of A·cos: P cycles of range 2A in all; DEL = 2A·(P / N_eq)^(1/m)."""
    A, periods, per = 120.0, 37, 50
    t = np.arange(periods * per + 1)
    x = A * np.cos(2 * np.pi * t / per)
    c = rainflow_cycles(x)
    assert np.allclose(c.range, 2 * A)
    assert c.count.sum() == pytest.approx(periods)
    n_eq = 1e7
    got = damage_equivalent_load(c, [m], n_eq)[0]
    assert got == pytest.approx(2 * A * (periods / n_eq) ** (1 / m), rel=1e-12)


def test_sum_of_sines_equals_four_point():
    """Three sines of incommensurate frequencies (a gear-mesh-like history): the library's
    cycles equal the independent four-point count, range by range."""
    t = np.arange(5000) * 1e-3
    x = 100 * np.sin(2 * np.pi * 1.3 * t) + 30 * np.sin(2 * np.pi * 17.1 * t + 0.4) \
        + 8 * np.sin(2 * np.pi * 93.7 * t + 1.1)
    c = rainflow_cycles(x)
    ref = four_point(x)
    got: dict[float, float] = {}
    for r, n in zip(c.range, c.count, strict=True):
        got[r] = got.get(r, 0.0) + n
    assert set(got) == set(ref)
    for r in ref:
        assert got[r] == pytest.approx(ref[r])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_library_equals_independent_four_point(seed):
    rng = np.random.default_rng(seed)
    x = np.round(rng.standard_normal(2000).cumsum() + 5 * rng.standard_normal(2000), 6)
    c = rainflow_cycles(x)
    ref = four_point(x)
    m = 4.0
    dmg_lib = np.sum(c.count * c.range ** m)
    dmg_ref = sum(n * r ** m for r, n in ref.items())
    assert dmg_lib == pytest.approx(dmg_ref, rel=1e-12)
    edges = np.linspace(0, c.range.max() + 1, 30)
    ref_hist, _ = np.histogram(list(ref), bins=edges, weights=list(ref.values()))
    assert np.allclose(range_histogram(c, edges), ref_hist)


def test_load_duration_of_a_held_level():
    """A signal at 10 N·m for 3 s and −5 N·m for 1 s (1 kHz): 3 s and 1 s at those levels."""
    dt = 1e-3
    x = np.r_[np.full(3000, 10.0), np.full(1000, -5.0)]
    edges = np.array([-10.0, 0.0, 20.0])
    assert np.allclose(load_duration(x, dt, edges), [1.0, 3.0])


def test_nonfinite_signal_refused():
    with pytest.raises(ValueError, match="NaN"):
        rainflow_cycles(np.array([0.0, np.nan, 1.0]))
