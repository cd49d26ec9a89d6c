"""Checks of channel values: NaN or inf, clipping, length. Each error names the file,
the channel, and the sample index."""

from __future__ import annotations

import numpy as np

from gbpipe.errors import DataError

__all__ = ["finite", "clipping", "length", "CLIP_RUN"]

#: this many equal consecutive samples at the channel's extreme count as a flat top
CLIP_RUN = 5


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(m))
    return edges[::2], edges[1::2] - edges[::2]


def finite(values: np.ndarray, source: str, bridge_upto: int = 0) -> np.ndarray:
    """Refuse NaN or inf samples, or bridge runs of at most ``bridge_upto`` linearly.

    Returns
    -------
    numpy.ndarray
        ``values``, with bridged runs filled.

    Raises
    ------
    gbpipe.errors.DataError
        At the first run that is not bridged (its start index and length).
    """
    bad = ~np.isfinite(values)
    if not bad.any():
        return values
    starts, lengths = _runs(bad)
    over = np.flatnonzero((lengths > bridge_upto) | (starts == 0)
                          | (starts + lengths == values.size))
    if over.size:
        i = over[0]
        why = "" if not bridge_upto else f" (longer than interpolate_upto = {bridge_upto}, " \
            "or at an end)"
        raise DataError(source, f"{lengths[i]} NaN/inf sample(s){why}; {int(bad.sum())} "
                        f"in all", sample=int(starts[i]))
    good = np.flatnonzero(~bad)
    out = values.copy()
    out[bad] = np.interp(np.flatnonzero(bad), good, values[good])
    return out


def clipping(values: np.ndarray, source: str,
             converter_range: tuple[float, float] | None = None, *,
             flat_top: bool = True) -> None:
    """Refuse a clipped channel.

    Clipped means: a sample at or beyond ``converter_range`` (when the mapping gives
    the converter's range), or a flat top — :data:`CLIP_RUN` or more consecutive samples
    equal to the channel's maximum or minimum, which a band-limited signal sampled above
    its Nyquist rate does not produce but a saturated converter does (``flat_top=False``
    skips this part, for signals that may legitimately rest at their extreme).
    """
    if values.size == 0:
        return
    if converter_range is not None:
        lo, hi = converter_range
        at = np.flatnonzero((values <= lo) | (values >= hi))
        if at.size:
            raise DataError(source, f"clipped: {at.size} sample(s) at the converter range "
                            f"[{lo:g}, {hi:g}] (field 'range')", sample=int(at[0]))
    if not flat_top:
        return
    for extreme, word in ((values.max(), "maximum"), (values.min(), "minimum")):
        starts, lengths = _runs(values == extreme)
        long_ = np.flatnonzero(lengths >= CLIP_RUN)
        if long_.size and values.max() > values.min():
            i = long_[0]
            raise DataError(source, f"clipped: flat top of {lengths[i]} samples at the "
                            f"{word} {extreme:g} ({long_.size} such run(s)); the converter "
                            f"saturated: lower the gain or widen its range",
                            sample=int(starts[i]))


def length(n: int, fs: float, source: str, min_duration: float | None) -> None:
    """Refuse an empty record, or one shorter than ``min_duration`` [s]."""
    if n < 2:
        raise DataError(source, f"{n} sample(s) on the record grid: nothing to analyse")
    if min_duration is not None and n / fs < min_duration:
        raise DataError(source, f"too short: {n / fs:.6g} s ({n} samples at {fs:g} Hz); "
                        f"the analysis needs at least {min_duration:.6g} s")
