"""What an identified FRF is scored against: the true model, or the data themselves.

A simulated record has a true model: the model stage's ``truth.nc`` holds its FRF on the
identification grid and its modes (:func:`truth_reference`). A measured record has none.
Its reference is then the nonparametric FRF of the same conditioned data: Welch cross-
spectra (:func:`gbpipe.sysid.welch_frf`), H1 in open loop or through a measured reference
signal in closed loop, with 95 % bounds from coherence and the number of averages
(:func:`nonparametric_reference`). That estimate judges a model only where it is coherent:
at the frequencies where the coherence of every element reaches
``identify.nonparametric.coherence_min``. Elsewhere (anti-resonances, the bands a
harmonic or noise dominates) the error is NaN, and no number is claimed there.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.identify.metrics import frf_error_db, match_bandwidth
from gbpipe.sysid import welch_frf

__all__ = ["Reference", "truth_reference", "nonparametric_reference", "within_reference",
           "reference_bandwidth"]


class Reference(NamedTuple):
    """The reference FRF of one pairing on the job's frequency grid.

    Attributes
    ----------
    kind : {"truth", "nonparametric"}
    frequency : ndarray, shape (F,)
        Grid [Hz].
    frf : ndarray, shape (F, ny, nu), complex
        Reference FRF (output unit per input unit).
    lower, upper : ndarray, shape (F, ny, nu)
        95 % bounds of ``|frf|`` (NaN for the truth: it is exact).
    coherence : ndarray, shape (F, ny, nu)
        Coherence of the estimate (NaN for the truth).
    modes, damping : ndarray
        True modes in the band [Hz] and their damping ratios [-] (empty for an estimate).
    description : str
        What the reference is, for tables and captions.
    assessable : ndarray of bool, shape (F,)
        Frequencies where the reference can judge a model: all for the truth; where the
        coherence of every element reaches ``coherence_min`` for an estimate.
    """

    kind: str
    frequency: np.ndarray
    frf: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    coherence: np.ndarray
    modes: np.ndarray
    damping: np.ndarray
    description: str
    assessable: np.ndarray

    @property
    def band_max(self) -> float:
        """Highest frequency the reference can assess [Hz] (the grid's top for the truth,
        the highest coherent frequency for an estimate; 0 when none is coherent)."""
        f = self.frequency[self.assessable]
        return float(f[-1]) if f.size else 0.0


def truth_reference(truth: xr.Dataset, pairing: Mapping[str, Any],
                    record: xr.Dataset | None = None) -> Reference:
    """True FRF and modes of one pairing from the model stage's ``truth.nc``.

    Parameters
    ----------
    truth : xarray.Dataset
        :func:`gbpipe.model.truth_dataset`.
    pairing : mapping
        One of ``identify.pairings`` (``name``, ``inputs``, ``outputs``).
    record : xarray.Dataset, optional
        The record identified: the units of its signals (``units`` attribute) must be
        those of the truth's ``input_units``/``output_units``, since the FRFs are compared
        in physical units (e.g. N m/N m = 1 for a motor torque -> torque meter pairing,
        rad/s per N m for a speed).

    Raises
    ------
    gbpipe.errors.DataError
        The pairing is not in ``truth``, its signals differ (a stale truth file), or a
        signal's unit differs from the truth's.
    """
    name, ins, outs = pairing["name"], list(pairing["inputs"]), list(pairing["outputs"])
    if name not in truth.pairing.values:
        raise DataError("truth.nc", f"has no pairing '{name}' (it holds "
                        f"{list(truth.pairing.values)}): rerun the model stage")
    sel = truth.sel(pairing=name)
    t_ins = [str(x) for x in sel.input_name.values[:len(ins)]]
    t_outs = [str(x) for x in sel.output_name.values[:len(outs)]]
    if t_ins != ins or t_outs != outs:
        raise DataError("truth.nc", f"pairing '{name}' is {t_ins} -> {t_outs}, the config "
                        f"says {ins} -> {outs}: rerun the model stage")
    if record is not None and "output_units" in sel.coords:
        want = dict(zip(t_ins + t_outs, [str(x) for x in sel.input_units.values[:len(ins)]]
                        + [str(x) for x in sel.output_units.values[:len(outs)]], strict=True))
        for sig, unit in want.items():
            got = str(record[sig].attrs.get("units", unit)) if sig in record else unit
            if got != unit:
                raise DataError(sig, f"is in {got!r} in the record but in {unit!r} in "
                                f"truth.nc (pairing '{name}'): store the record in SI "
                                "units (gbpipe.units) or rerun the model stage")
    g = (sel.frf_true_real.values + 1j * sel.frf_true_imag.values)[:, :len(outs), :len(ins)]
    fm, zm = sel.mode_frequency_true.values, sel.mode_damping_true.values
    keep = np.isfinite(fm)
    f = np.asarray(truth.frequency.values, dtype=float)
    nan = np.full(g.shape, np.nan)
    return Reference("truth", f, g, nan, nan, nan, fm[keep], zm[keep],
                     "true model (bench model, other loop closed)", np.ones(f.size, bool))


def nonparametric_reference(u: np.ndarray | Sequence[np.ndarray],
                            y: np.ndarray | Sequence[np.ndarray], fs: float,
                            s: Mapping[str, Any],
                            r: np.ndarray | Sequence[np.ndarray] | None = None) -> Reference:
    """Nonparametric FRF of conditioned data, on its Welch grid within the FRF band.

    Parameters
    ----------
    u, y : ndarray, shape (n, nu) and (n, ny), or a list of such segments
        Conditioned identification data (operating point removed, decimated) [SI].
    fs : float
        Their sample rate [Hz].
    s : mapping
        The validated ``identify`` section (``frf``, ``nonparametric``).
    r : ndarray or list, optional
        A measured reference (set-point) signal per segment: the closed-loop estimate
        through the reference (:func:`gbpipe.sysid.welch_frf` ``estimator="reference"``).
        Without it, H1, which is biased where feedback correlates input and noise.

    Returns
    -------
    Reference
    """
    npc = s["nonparametric"]
    est = welch_frf(u, y, fs, reference=r, nperseg=int(round(npc["segment"] * fs)),
                    estimator="reference" if r is not None else "h1")
    f = est.frequency
    band = (f >= s["frf"]["f_min"]) & (f <= s["frf"]["f_max"])
    f = f[band]
    coh = est.coherence[band]
    # a frequency is assessable where every element's coherence reaches the threshold;
    # elsewhere the estimate is mostly noise and nothing measured there is claimed
    ok = np.all(coh.reshape(len(f), -1) >= npc["coherence_min"], axis=1)
    what = ("closed-loop estimate through the reference" if r is not None else "H1 estimate")
    return Reference("nonparametric", f, est.frf[band], est.magnitude_lower[band],
                     est.magnitude_upper[band], coh, np.array([]), np.array([]),
                     f"nonparametric {what} (Welch, {est.n_averages:.0f} averages; assessed "
                     f"where coherence >= {npc['coherence_min']:g}: {100 * ok.mean():.0f} % "
                     f"of {f[0]:.0f}-{f[-1]:.0f} Hz)", ok)


def within_reference(g_id: np.ndarray, ref: Reference, tol_db: float) -> np.ndarray:
    """Error of ``g_id`` against the reference [dB], zero where it is within tolerance.

    Against the truth this is :func:`gbpipe.identify.frf_error_db`. Against an estimate,
    an identified FRF inside the estimate's 95 % bounds is as good as the data can tell
    (error set to 0), and where the estimate is not coherent the error is NaN.
    """
    err = frf_error_db(g_id, ref.frf)
    if ref.kind == "truth":
        return err
    mag = np.abs(g_id)
    inside = (mag >= ref.lower) & (mag <= ref.upper)
    err = np.where(inside & (np.abs(err) > tol_db), 0.0, err)
    err[~ref.assessable] = np.nan
    return err


def reference_bandwidth(f: np.ndarray, err: np.ndarray, ref: Reference, tol_db: float) -> float:
    """Match bandwidth against a reference [Hz]: :func:`gbpipe.identify.match_bandwidth`
    over the frequencies the reference can assess (all of them for the truth)."""
    keep = ref.assessable
    return match_bandwidth(f[keep], err[keep], tol_db) if keep.any() else 0.0
