"""Tests of gbpipe.harmonics.pieces: a removal of a long record in overlapping pieces."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from gbpipe.harmonics.joint import residual_joint
from gbpipe.harmonics.pieces import block_margin, by_pieces

FS = 2000.0  # Hz


def _record(n: int, seed: int = 0):
    """A shaft near 20 rev/s whose speed wanders, a line at order 3 and one at 7.3,
    white noise; its pulses (1 per rev) from the true angle."""
    t = np.arange(n) / FS
    rng = np.random.default_rng(seed)
    omega = 2 * np.pi * (20 + 0.5 * np.sin(2 * np.pi * t / 100))  # rad/s
    theta = np.cumsum(omega) / FS
    x = np.sin(3 * theta) + 0.5 * np.sin(7.3 * theta) + 0.3 * rng.standard_normal(n)
    pulses = np.interp(2 * np.pi * np.arange(1, int(theta[-1] / (2 * np.pi))), theta, t)
    return t, theta, x, pulses


def test_pieces_stitch_the_time_axis_and_hand_each_its_own_pulses():
    # a removal that returns each sample's time and checks its pulses: the stitched
    # result is the record's time axis, so every kept sample came from its own piece at
    # its own offset
    t, _, x, pulses = _record(50_000)

    def times(piece: np.ndarray, p: np.ndarray, t0: float) -> np.ndarray:
        end = t0 + (piece.size - 1) / FS
        assert p.size and p.min() >= t0 and p.max() <= end
        assert np.array_equal(p, pulses[(pulses >= t0) & (pulses <= end)])
        return t0 + np.arange(piece.size) / FS

    out = by_pieces(x, FS, pulses, margin=1_000, remove=times, piece=7_000)
    np.testing.assert_allclose(out, t, rtol=0, atol=1e-9)


def test_a_record_within_one_piece_is_removed_in_one_call():
    _, _, x, pulses = _record(30_000)
    calls = []

    def whole(piece, p, t0):
        calls.append((piece.size, t0))
        return piece * 2.0

    out = by_pieces(x, FS, pulses, margin=1_000, remove=whole, piece=28_000)
    assert calls == [(x.size, 0.0)]
    np.testing.assert_array_equal(out, 2.0 * x)


def test_joint_tsa_in_pieces_removes_the_families_as_well_as_on_the_whole_record():
    # the two families' lines go as far down in pieces as in one call, and what is left
    # differs from the whole record's only by the noise of a block mean (the blocks fall
    # elsewhere in a piece): rms of the difference ~ noise / sqrt(n_cycles)
    _, theta, x, pulses = _record(240_000)
    cycles, n_cycles = [Fraction(1), Fraction(10, 73)], 10

    def joint(piece, p, t0):
        return residual_joint(piece, FS, p, cycles, n_cycles, 1, outside="keep", t0=t0)

    whole = joint(x, pulses, 0.0)
    margin = block_margin(pulses, 1, FS, [float(c) for c in cycles], n_cycles)
    # one block of the 7.3-revolution cycle at the slowest speed and a revolution
    assert margin == int(np.ceil((10 * 7.3 + 1) * np.diff(pulses).max() * FS))
    pieces = by_pieces(x, FS, pulses, margin, joint, piece=60_000)

    def line(r, order):
        a = np.column_stack([np.sin(order * theta), np.cos(order * theta)])
        return float(np.hypot(*np.linalg.lstsq(a, r, rcond=None)[0]))

    # from 1.0 to the noise's own least-squares amplitude (rms 0.3 sqrt(2 / n)), both ways
    floor = 0.3 * np.sqrt(2 / x.size)
    assert line(whole, 3) < 3 * floor and line(pieces, 3) < 3 * floor
    assert 0.45 < line(pieces, 7.3) / 0.5 < 1.05          # not a family's: kept
    assert np.std(pieces - whole) < 1.5 * 0.3 / np.sqrt(n_cycles)
    assert abs(np.std(pieces) / np.std(whole) - 1) < 0.01


def test_pieces_written_over_the_record_equal_a_local_filter_of_the_whole_record():
    # a removal that looks up to ``w`` samples either side (x minus its centred moving
    # average) is local: in pieces whose margins exceed ``w`` every kept sample is the
    # whole record's, written over the record itself or not; over the record, a piece's
    # left margin must still be the record when that piece reads it
    _, _, x, pulses = _record(50_000, seed=3)
    w = 400
    kernel = np.ones(2 * w + 1) / (2 * w + 1)

    def detrend(piece: np.ndarray, p: np.ndarray, t0: float) -> np.ndarray:
        return piece - np.convolve(piece, kernel, mode="same")

    whole = detrend(x, pulses, 0.0)
    inner = slice(w, x.size - w)  # (the ends see the zero padding in either way)
    record = np.column_stack([x, -2 * x])  # two channels, time first
    out = by_pieces(record, FS, pulses, margin=1_000, piece=7_000, out=record,
                    remove=lambda r, p, t0: np.column_stack([detrend(c, p, t0) for c in r.T]))
    assert out is record
    np.testing.assert_allclose(record[inner, 0], whole[inner], rtol=0, atol=1e-12)
    np.testing.assert_allclose(record[inner, 1], -2 * whole[inner], rtol=0, atol=1e-12)
    # a new array by default, the record left as it was
    again = x.copy()
    np.testing.assert_allclose(by_pieces(again, FS, pulses, 1_000, detrend, 7_000)[inner],
                               whole[inner], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(again, x)
