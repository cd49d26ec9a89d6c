"""Fitting physical parameters to a modal table: identified frequencies and damping ratios.

A user who has only identified modes (frequency [Hz], damping ratio [-], each with its
spread, e.g. gbpipe's own ``tables/modes_measured.csv``) can fit the same parameters as
from FRFs (:func:`gbpipe.fit.estimate.fit_parameters` with a :class:`ModalData`). The
residuals are ``(f_model − f_data)/σ_f`` and ``(ζ_model − ζ_data)/σ_ζ`` of each data mode
and the model mode matched to it: the model's oscillatory modes in the band are paired
with the data's by ``scipy.optimize.linear_sum_assignment`` on the distance in
log-frequency, each model mode used at most once.

Which system's modes: ``plant`` (the open-loop bench, both motor loops open: what an
operational modal analysis of the bench at rest sees) or a pairing's closed loop
(:func:`gbpipe.model.truth_model`: the loop of the motor outside the pairing closed, what
an identification of that pairing sees). See docs/fit.md.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from gbpipe.errors import DataError
from gbpipe.fit.identifiability import JACOBIAN_STEP
from gbpipe.fit.parameters import FreeParameters
from gbpipe.lti import modes
from gbpipe.model.assembly import bench_ss
from gbpipe.model.frf import Pairing
from gbpipe.model.truth import truth_model

__all__ = ["ModalData", "ModalResiduals", "ModeTable", "read_modes_table", "model_modes",
           "match_modes", "modal_data_of", "MODE_COLUMNS"]

#: Columns a modal table must have (as in ``tables/modes_measured.csv``).
MODE_COLUMNS = ("frequency_hz", "damping", "frequency_spread_hz", "damping_spread")


@dataclass
class ModalData:
    """Identified modes to fit.

    Attributes
    ----------
    frequency_hz, damping : ndarray
        Natural frequency [Hz] and damping ratio [-] of each mode.
    frequency_sd, damping_sd : ndarray
        Their standard deviations (spreads) [Hz], [-], > 0.
    system : Pairing or None
        Whose modes: a pairing's closed loop, or None for the open-loop plant.
    band : (float, float)
        Model modes matched are those in this band [Hz] (default: all).
    source : str
        Where the table came from (for messages).
    """

    frequency_hz: np.ndarray
    damping: np.ndarray
    frequency_sd: np.ndarray
    damping_sd: np.ndarray
    system: Pairing | None = None
    band: tuple[float, float] = (0.0, np.inf)
    source: str = "modal table"

    def __post_init__(self) -> None:
        arrays = [np.atleast_1d(np.asarray(a, dtype=float)) for a in (
            self.frequency_hz, self.damping, self.frequency_sd, self.damping_sd)]
        if len({a.size for a in arrays}) != 1 or arrays[0].size == 0:
            raise DataError(self.source, "give one frequency, damping ratio and both "
                                         "spreads per mode, at least one mode")
        self.frequency_hz, self.damping, self.frequency_sd, self.damping_sd = arrays
        for name, a, positive in (("frequency_hz", arrays[0], True),
                                  ("damping", arrays[1], False),
                                  ("frequency_spread_hz", arrays[2], True),
                                  ("damping_spread", arrays[3], True)):
            bad = ~np.isfinite(a) | ((a <= 0) if positive else np.zeros(a.size, bool))
            if bad.any():
                raise DataError(self.source, f"{name} of mode {int(np.argmax(bad)) + 1} is "
                                f"{a[bad][0]}: must be finite{' and > 0' if positive else ''}"
                                " (a spread of 0 claims infinite precision: give the "
                                "spread, or leave the mode out)")


def read_modes_table(path: str | os.PathLike, pairing: str | None = None,
                     method: str | None = None, system: Pairing | None = None,
                     band: tuple[float, float] = (0.0, np.inf)) -> ModalData:
    """Read a modal table (CSV with :data:`MODE_COLUMNS`; more columns are ignored).

    Parameters
    ----------
    path : path-like
        The CSV file.
    pairing, method : str, optional
        Keep only rows of this ``pairing`` / ``method`` column (gbpipe's
        ``modes_measured.csv`` lists each mode per pairing and method).
    system, band
        See :class:`ModalData`.

    Raises
    ------
    DataError
        A missing column, a filter column absent, or no row left.
    """
    table = pd.read_csv(path)
    for col in MODE_COLUMNS:
        if col not in table.columns:
            raise DataError(str(path), f"no column '{col}': a modal table needs "
                                       f"{', '.join(MODE_COLUMNS)}")
    for col, value in (("pairing", pairing), ("method", method)):
        if value is not None:
            if col not in table.columns:
                raise DataError(str(path), f"no column '{col}' to select '{value}' by")
            table = table[table[col].astype(str) == value]
    if table.empty:
        raise DataError(str(path), f"no mode left (pairing {pairing}, method {method})")
    columns = []
    for col in MODE_COLUMNS:
        values = pd.to_numeric(table[col], errors="coerce").to_numpy(float)
        bad = np.isnan(values) & table[col].notna().to_numpy()
        if bad.any():
            raise DataError(str(path), f"column '{col}' row {int(np.argmax(bad)) + 1}: "
                            f"'{table[col].iloc[int(np.argmax(bad))]}' is not a number")
        columns.append(values)
    return ModalData(*columns, system=system, band=band, source=str(path))


def model_modes(cfg: dict, system: Pairing | None) -> tuple[np.ndarray, np.ndarray]:
    """Oscillatory modes (frequency [Hz] ascending, damping ratio [-]) of the model.

    Parameters
    ----------
    cfg : dict
        Validated configuration.
    system : Pairing or None
        A pairing's closed loop (:func:`gbpipe.model.truth_model`), or the open-loop plant.
    """
    if system is None:
        return modes(bench_ss(cfg, closed=False).A)
    return modes(truth_model(cfg, system.inputs, system.outputs).A)


def match_modes(f_model: np.ndarray, f_data: np.ndarray) -> np.ndarray:
    """Index of the model mode matched to each data mode (distance in log-frequency,
    each model mode at most once; ``linear_sum_assignment``)."""
    cost = np.abs(np.log(f_data)[:, None] - np.log(f_model)[None, :])
    rows, cols = linear_sum_assignment(cost)
    out = np.empty(f_data.size, dtype=int)
    out[rows] = cols
    return out


@dataclass
class ModeTable:
    """Mode by mode: the data, and the matched model modes at the prior and fitted.

    Attributes
    ----------
    frequency_data, damping_data, frequency_sd, damping_sd : ndarray
        [Hz], [-], [Hz], [-].
    frequency_prior, damping_prior, frequency_fitted, damping_fitted : ndarray
        The matched model modes [Hz], [-].
    """

    frequency_data: np.ndarray
    damping_data: np.ndarray
    frequency_sd: np.ndarray
    damping_sd: np.ndarray
    frequency_prior: np.ndarray
    damping_prior: np.ndarray
    frequency_fitted: np.ndarray
    damping_fitted: np.ndarray

    def text(self) -> str:
        """One line per mode: data, prior and fitted frequency with their errors [%]."""
        lines = ["mode   data [Hz]  damping   prior [Hz] (error)    fitted [Hz] (error)"]
        for k, fd in enumerate(self.frequency_data):
            fp, ff = self.frequency_prior[k], self.frequency_fitted[k]
            lines.append(f"{k + 1:4d} {fd:11.4g} {self.damping_data[k]:8.3g} "
                         f"{fp:11.4g} ({100 * (fp / fd - 1):+7.2f} %) "
                         f"{ff:11.4g} ({100 * (ff / fd - 1):+7.2f} %)")
        return "\n".join(lines)


class ModalResiduals:
    """Weighted residuals of the model's modes against a modal table.

    Parameters
    ----------
    free : FreeParameters
    data : ModalData

    Raises
    ------
    DataError
        The model at the prior has fewer modes in the band than the table.
    """

    def __init__(self, free: FreeParameters, data: ModalData) -> None:
        self.free, self.data = free, data
        self.n = len(free.paths)
        self.n_evaluations = 0
        n_modes = data.frequency_hz.size
        have = self._modes(np.zeros(self.n))[0].size
        if have < n_modes:
            raise DataError(data.source, f"{n_modes} modes, but the model has only {have} "
                            f"in {list(data.band)} Hz: leave modes out or widen the band")
        self.sequences = np.arange(2 * n_modes)      # no order along frequency: independent
        self.groups = np.tile([f"mode {k + 1} ({f:.3g} Hz)"
                               for k, f in enumerate(data.frequency_hz)], 2)
        self.frequency = np.tile(data.frequency_hz, 2)
        self.weight = 1.0 / np.concatenate([data.frequency_sd, data.damping_sd])
        self.has_sigma = True

    @property
    def size(self) -> int:
        """Number of residuals."""
        return int(self.weight.size)

    def _modes(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.n_evaluations += 1
        f, z = model_modes(self.free.config(theta[:self.n]), self.data.system)
        lo, hi = self.data.band
        keep = (f >= lo) & (f <= hi)
        return f[keep], z[keep]

    def matched(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Frequency [Hz] and damping [-] of the model mode matched to each data mode."""
        f, z = self._modes(theta)
        if f.size < self.data.frequency_hz.size:    # a mode left the band: match among all
            f, z = model_modes(self.free.config(theta[:self.n]), self.data.system)
        idx = match_modes(f, self.data.frequency_hz)
        return f[idx], z[idx]

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """``(f_model − f_data)/σ_f`` of every mode, then ``(ζ_model − ζ_data)/σ_ζ``."""
        f, z = self.matched(theta)
        d = self.data
        return self.weight * np.concatenate([f - d.frequency_hz, z - d.damping])

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residual` with respect to ``θ`` (central differences)."""
        cols = []
        for i in range(theta.size):
            e = np.zeros_like(theta)
            e[i] = JACOBIAN_STEP
            cols.append((self.residual(theta + e) - self.residual(theta - e))
                        / (2 * JACOBIAN_STEP))
        return np.column_stack(cols)

    def table(self, theta_prior: np.ndarray, theta_fit: np.ndarray) -> ModeTable:
        """The mode-by-mode comparison at the prior and at the fit."""
        d = self.data
        return ModeTable(d.frequency_hz, d.damping, d.frequency_sd, d.damping_sd,
                         *self.matched(theta_prior), *self.matched(theta_fit))


def modal_data_of(cfg: dict, system: Pairing | None, f_max: float, spread: float,
                  damping_spread: float, rng: np.random.Generator,
                  source: str = "simulated modes") -> ModalData:
    """Modes of a (perturbed) model with relative spreads, drawn around the truth.

    A test and benchmark helper: each frequency is the model's times ``1 + spread·n``,
    each damping ratio times ``1 + damping_spread·n`` (``n`` standard normal from
    ``rng``), and the spreads are these relative standard deviations of the true values.

    Parameters
    ----------
    cfg : dict
        The configuration whose modes are the data.
    system : Pairing or None
    f_max : float
        Highest mode kept [Hz].
    spread, damping_spread : float
        Relative standard deviation of the frequencies and of the damping ratios [-].
    rng : numpy.random.Generator
    source : str
        Name of the data (for messages).
    """
    f, z = model_modes(cfg, system)
    keep = (f <= f_max) & (z > 0)
    f, z = f[keep], z[keep]
    return ModalData(f * (1 + spread * rng.standard_normal(f.size)),
                     z * (1 + damping_spread * rng.standard_normal(z.size)), spread * f,
                     damping_spread * z, system, source=source)
