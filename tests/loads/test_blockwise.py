"""Load spectra of a signal given block by block against the ``rainflow`` library and
numpy on the whole signal: the reversals of the library, its cycle count (identical), the
time at level and the damage-equivalent loads, on random signals with flat runs split at
random places (blocks of one sample, flat runs across block edges)."""

from __future__ import annotations

import numpy as np
import pytest
import rainflow

from gbpipe.loads import BlockSpectrum, turning_points


def _signal(rng: np.random.Generator, n: int, kind: str) -> np.ndarray:
    if kind == "noisy":        # a measured torque: a slow swing under white noise
        t = np.arange(n)
        return 300 * np.sin(2 * np.pi * t / 900) + 20 * rng.standard_normal(n)
    if kind == "quantised":    # an ADC's steps: many flat runs and repeated levels
        return np.round(np.cumsum(rng.standard_normal(n)) / 2.0)
    # a smooth estimate with long flat stretches
    x = np.cumsum(rng.standard_normal(n))
    x[rng.random(n) < 0.3] = 0.0
    return np.repeat(x[: n // 3], 3)[:n] if n >= 3 else x


def _splits(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    cuts = np.unique(np.concatenate([[0, n], rng.integers(1, max(n, 2), 12),
                                     rng.integers(1, max(n, 2), 3)]))
    cuts = cuts[cuts <= n]
    # a block of a single sample too
    extra = [c + 1 for c in cuts[1:-1] if c + 1 < n][:2]
    return [np.arange(a, b) for a, b in zip(*(lambda c: (c[:-1], c[1:]))(
        np.unique(np.concatenate([cuts, extra]))), strict=True)]


@pytest.mark.parametrize("kind", ["noisy", "quantised", "flat"])
@pytest.mark.parametrize("seed", range(4))
def test_turning_points_are_the_library_reversals(kind, seed):
    rng = np.random.default_rng(seed)
    for n in (0, 1, 2, 3, 5, 400):
        x = _signal(rng, n, kind)
        # the library gives only the first of two samples; a block keeps both
        want = [v for _, v in rainflow.reversals(x)] if n > 2 else list(x)
        assert turning_points(x).tolist() == want


@pytest.mark.parametrize("kind", ["noisy", "quantised", "flat"])
@pytest.mark.parametrize("seed", range(5))
def test_concatenated_turning_points_count_as_the_whole_signal(kind, seed):
    rng = np.random.default_rng(100 + seed)
    x = _signal(rng, 3000, kind)
    blocks = _splits(rng, len(x))
    assert np.array_equal(np.concatenate(blocks), np.arange(len(x)))
    turns = np.concatenate([turning_points(x[i]) for i in blocks])
    assert rainflow.count_cycles(turns) == rainflow.count_cycles(x)
    # each cycle, its mean and count too, in the same order
    assert [c[:3] for c in rainflow.extract_cycles(turns)] == \
           [c[:3] for c in rainflow.extract_cycles(x)]


@pytest.mark.parametrize("seed", range(3))
def test_block_spectrum_equals_the_whole_signal(seed):
    rng = np.random.default_rng(200 + seed)
    x = _signal(rng, 5000, ["noisy", "quantised", "flat"][seed])
    dt, bins, slopes, f_eq = 2e-4, 16, [3.0, 4.0, 10.0], 1.0
    spec = BlockSpectrum(float(x.min()), float(x.max()), bins, dt)
    for i in _splits(rng, len(x)):
        spec.add(x[i])
    got = spec.result(slopes, f_eq)
    # the whole signal, by numpy and the library's own count
    edges = np.linspace(x.min(), x.max(), bins + 1)
    assert np.array_equal(got.time_at_level, np.histogram(x, edges)[0] * dt)
    assert got.time_at_level.sum() == pytest.approx(len(x) * dt, rel=1e-12)
    pairs = rainflow.count_cycles(x)
    ranges = np.array([r for r, _ in pairs])
    counts = np.array([n for _, n in pairs])
    redges = np.linspace(0.0, ranges.max(), bins + 1)
    assert np.allclose(got.cycle_count, np.histogram(ranges, redges, weights=counts)[0],
                       rtol=0, atol=1e-9)
    assert np.allclose(got.range_centre, 0.5 * (redges[1:] + redges[:-1]), rtol=1e-15)
    n_eq = f_eq * len(x) * dt
    want = [(np.sum(counts * ranges ** m) / n_eq) ** (1 / m) for m in slopes]
    assert np.allclose(got.del_, want, rtol=1e-12, atol=0)


def test_non_finite_block_refused():
    spec = BlockSpectrum(0.0, 1.0, 4, 1e-3)
    with pytest.raises(ValueError, match="NaN or inf"):
        spec.add(np.array([0.0, np.nan, 1.0]))


@pytest.mark.parametrize("n", [3, 4, 50])
def test_monotonic_signal_is_one_half_cycle(n):
    """No reversal inside: the whole count is one half cycle, first to last sample."""
    x = np.linspace(-5.0, 7.0, n) ** 3
    spec = BlockSpectrum(float(x.min()), float(x.max()), 4, 1.0)
    for i in np.array_split(np.arange(n), 1 if n < 4 else 3):
        spec.add(x[i])
    got = spec.result([4.0], 1.0)
    assert rainflow.count_cycles(x) == [(x[-1] - x[0], 0.5)]
    assert got.cycle_count.sum() == 0.5
    assert got.del_[0] == pytest.approx((0.5 * (x[-1] - x[0]) ** 4 / n) ** 0.25, rel=1e-12)
