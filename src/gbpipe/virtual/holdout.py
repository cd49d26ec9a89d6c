"""The held-out sensors against their estimates, accumulated block by block (hour-long
records, issue 47): the fit with the means removed and with them, the RMS error and the
share of samples inside the band, as :func:`gbpipe.lti.fit_percent` and plain means give
them on the whole series.

Each block adds its count, its means and its sums of squares about them (of the error and
of the measurement), merged by Chan, Golub and LeVeque's pairwise update: no sum of large
squares is subtracted from another, so the result equals the whole series' to round-off
whatever the offset of the signal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["HoldoutFit"]


@dataclass
class _Moments:
    """Count, mean and sum of squares about the mean of each column of a series."""

    count: int
    mean: np.ndarray
    m2: np.ndarray

    @classmethod
    def of(cls, x: np.ndarray) -> _Moments:
        mean = x.mean(axis=0)
        return cls(len(x), mean, np.sum((x - mean) ** 2, axis=0))

    def merge(self, other: _Moments) -> None:
        n = self.count + other.count
        delta = other.mean - self.mean
        self.mean = self.mean + delta * (other.count / n)
        self.m2 = self.m2 + other.m2 + delta ** 2 * (self.count * other.count / n)
        self.count = n


class HoldoutFit:
    """Held-out measurements against their estimates, given in blocks (any order).

    Parameters
    ----------
    half_width : ndarray (h,)
        Half width of each held-out signal's 95 % band [its unit] (the estimate's and the
        sensor's own noise).
    """

    def __init__(self, half_width: np.ndarray) -> None:
        self.half_width = np.asarray(half_width, dtype=float)
        self._error: _Moments | None = None
        self._measured: _Moments | None = None
        self._inside = np.zeros(len(self.half_width))

    def add(self, measured: np.ndarray, estimate: np.ndarray) -> None:
        """One block: measurements and estimates (n, h) [their units]."""
        err = measured - estimate
        self._inside += np.sum(np.abs(err) <= self.half_width, axis=0)
        e, m = _Moments.of(err), _Moments.of(measured)
        if self._error is None:
            self._error, self._measured = e, m
        else:
            self._error.merge(e)
            self._measured.merge(m)

    def result(self) -> dict[str, np.ndarray]:
        """Per held-out signal: ``fit_percent`` (means removed), ``fit_percent_with_mean``
        [%] (``100 (1 − ‖error‖ / ‖m − mean m‖)``, ``-inf`` where undefined, as
        :func:`gbpipe.lti.fit_percent`), ``rms_error`` [its unit], ``coverage_95`` [-]."""
        if self._error is None:
            raise ValueError("no block added")
        e, m = self._error, self._measured
        with np.errstate(all="ignore"):
            den = np.sqrt(m.m2)
            total = e.m2 + e.count * e.mean ** 2          # ‖error‖², the means kept
            fit = 100.0 * (1.0 - np.sqrt(e.m2) / den)
            fit_mean = 100.0 * (1.0 - np.sqrt(total) / den)
        return {"fit_percent": np.where(np.isfinite(fit), fit, -np.inf),
                "fit_percent_with_mean": np.where(np.isfinite(fit_mean), fit_mean, -np.inf),
                "rms_error": np.sqrt(total / e.count),
                "coverage_95": self._inside / e.count}
