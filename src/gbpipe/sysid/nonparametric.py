"""Nonparametric frequency response from Welch cross-spectra, with 95 % confidence bounds.

For a measured record there is no true model: the reference a parametric model is drawn
against is the FRF estimated directly from averaged cross-spectra, with bounds that say
where that estimate can be trusted (docs/sysid.md, "Nonparametric FRF").

* :func:`welch_frf` -- H1, errors-in-variables (Hv, SISO) or closed-loop (through a
  measured reference) FRF, coherence and 95 % bounds of one or several records;
* :func:`equivalent_averages` -- number of independent averages of overlapped windows;
* :func:`coherent_band` -- the frequencies where the coherence reaches a threshold.

Spectra: whole windows of ``nperseg`` samples (window ``k`` starts at sample
``k * (nperseg - noverlap)``) from :class:`scipy.signal.ShortTimeFFT`, each detrended; the
cross-spectral matrix is the mean of the window products, :func:`scipy.signal.csd`'s
numbers up to a scale that cancels in every ratio returned. Records are pooled window by
window (each weighs by its number of windows).

Bounds: per frequency the estimate is a regression of the output spectra on those of the
instruments ``z`` (``u`` for H1, ``r`` for the reference estimate), ``Ĥᵀ = P S_zy`` with
``P = S_zu⁺``. With complex Gaussian residuals ``v = y - H u`` independent of ``z``, element
``(a, i)`` obeys (Bendat & Piersol, *Random Data*, 4th ed., 2010, ch. 9; Pintelon
& Schoukens, *System Identification*, 2nd ed., 2012, ch. 2)::

    |Ĥ_ai - H_ai|² / (Ĝ_vv,a [P S_zz Pᴴ]_ii / (n_d - n_u))  ~  F(2, 2 (n_d - n_u))

``Ĝ_vv,a``: mean residual power of output ``a``. For SISO H1 this is the circle
``r² = F_{2, 2(n_d-1)} / (n_d - 1) · (1 - γ²)/γ² · |Ĥ|²``. The quantile is per element (a
joint region for a row would use ``n_u F_{2n_u, 2(n_d-n_u)}``, wider). At DC and Nyquist
the spectra are real: ``F(1, n_d - n_u)``. ``n_d`` is :func:`equivalent_averages`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import stats
from scipy.signal import ShortTimeFFT, get_window

from gbpipe.errors import ConfigError, DataError
from gbpipe.sysid.checks import as_2d, check_finite

__all__ = ["NonparametricFRF", "CoherentBand", "welch_frf", "equivalent_averages",
           "coherent_band", "ESTIMATORS"]

#: Estimators :func:`welch_frf` knows.
ESTIMATORS = ("h1", "hv", "reference")
# Windows transformed at a time: bounds the memory of long records to a few MB per channel.
_SLICES_PER_BLOCK = 512


class NonparametricFRF(NamedTuple):
    """FRF estimated from averaged cross-spectra, with its coherence and 95 % bounds.

    Attributes
    ----------
    frequency : ndarray, shape (F,)
        Frequencies [Hz] (one-sided, ``0 .. fs/2`` in steps of ``fs / nperseg``).
    frf : ndarray of complex, shape (F, ny, nu)
        Estimated frequency response [output unit per input unit]; SISO gives (F, 1, 1).
    coherence : ndarray, shape (F, ny, nu)
        Squared coherence [1], in [0, 1]: ordinary coherence (SISO) or the multiple
        coherence of each output with all inputs (``"h1"``, ``"hv"``) or with all reference
        channels (``"reference"``); repeated along the input axis.
    n_averages : float
        Equivalent number of independent averages [1] (overlap accounted for), summed over
        the records.
    magnitude_lower, magnitude_upper : ndarray, shape (F, ny, nu)
        Bounds of ``|frf|`` [output unit per input unit] at confidence ``level``:
        ``|Ĥ| ∓ r`` with ``r`` the radius of the confidence circle around ``Ĥ`` (lower
        clipped at 0). ``magnitude_upper - |frf|`` is ``r``.
    phase_halfwidth : ndarray, shape (F, ny, nu)
        Half-width [rad] of the phase interval, ``arcsin(r / |Ĥ|)``; ``π`` where
        ``r >= |Ĥ|`` (the circle holds the origin: any phase).
    level : float
        Confidence level of the bounds [1], e.g. 0.95.
    estimator : str
        ``"h1"``, ``"hv"`` or ``"reference"``.
    """

    frequency: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    n_averages: float
    magnitude_lower: np.ndarray
    magnitude_upper: np.ndarray
    phase_halfwidth: np.ndarray
    level: float
    estimator: str


class CoherentBand(NamedTuple):
    """Where an estimate is coherent (:func:`coherent_band`).

    Attributes
    ----------
    mask : ndarray of bool, shape (F, ny, nu)
        True where the squared coherence is at least the threshold.
    f_low, f_high : ndarray, shape (ny, nu)
        Edges [Hz] (first and last frequency) of the longest contiguous run of coherent
        frequencies of each element; NaN where no frequency is coherent.
    """

    mask: np.ndarray
    f_low: np.ndarray
    f_high: np.ndarray


def equivalent_averages(window: str | tuple | np.ndarray, nperseg: int, noverlap: int,
                        n_segments: int) -> float:
    """Equivalent number of independent averages of a Welch estimate [1].

    Overlapping windows are correlated, so ``K`` overlapped windows average out less
    noise than ``K`` independent ones. Welch (1967, IEEE Trans. Audio Electroacoust.
    15(2), 70-73; Percival & Walden, *Spectral Analysis for Physical Applications*, 1993,
    WOSA) gives, for Gaussian noise with a spectrum flat over the window's resolution,
    ``var(Ŝ)/S² = 1/K_eq`` with::

        1/K_eq = (1/K) [1 + 2 Σ_{j=1}^{K-1} (1 - j/K) ρ(j)],
        ρ(j) = (Σ_n w[n] w[n + j D])² / (Σ_n w[n]²)²,      D = nperseg - noverlap.

    ``K_eq = K`` without overlap; Hann windows at 50 % overlap have ``ρ(1) = 1/36``.

    Parameters
    ----------
    window : str, tuple or ndarray
        Window as for :func:`scipy.signal.get_window`, or its samples.
    nperseg : int
        Window length [samples].
    noverlap : int
        Overlap of consecutive windows [samples], ``0 <= noverlap < nperseg``.
    n_segments : int
        Number of windows ``K`` [1].

    Returns
    -------
    float
        ``K_eq`` [1], between ``K / (1 + 2 Σ ρ)`` and ``K``.
    """
    w = _window(window, nperseg)
    hop = nperseg - noverlap
    energy = np.dot(w, w)
    lags = np.arange(1, min(n_segments, -(-nperseg // hop)))
    rho = np.array([np.dot(w[: nperseg - j * hop], w[j * hop:]) ** 2 for j in lags]) / energy**2
    inflation = 1.0 + 2.0 * np.sum((1.0 - lags / n_segments) * rho)
    return float(n_segments / inflation)


def welch_frf(u, y, fs: float, *, reference=None, nperseg: int, noverlap: int | None = None,
              window: str | tuple | np.ndarray = "hann", estimator: str = "h1",
              level: float = 0.95, detrend: str | bool | None = "constant"
              ) -> NonparametricFRF:
    """Nonparametric FRF from y to u by Welch-averaged cross-spectra, with bounds.

    Parameters
    ----------
    u : array_like, shape (N,) or (N, nu), or a list of such arrays
        Input [input unit]. A list holds several records (or segments of one record,
        e.g. split at gaps); their cross-spectra are pooled window by window.
    y : array_like, shape (N,) or (N, ny), or a list of such arrays
        Output [output unit], same number of samples (and records) as ``u``.
    fs : float
        Sample rate [Hz].
    reference : array_like, shape (N,) or (N, nr), or a list of such arrays, optional
        Measured reference (set-point) [any unit], needed by ``estimator="reference"``
        with ``nr >= nu``; it must be independent of the noise in the loop.
    nperseg : int
        Window length [samples]; the resolution is ``fs / nperseg`` [Hz].
    noverlap : int, optional
        Overlap [samples]; default ``nperseg // 2``.
    window : str, tuple or ndarray
        Window as for :func:`scipy.signal.get_window` (default Hann, periodic).
    estimator : {"h1", "hv", "reference"}
        ``"h1"``: ``H = S_yu S_uu⁻¹``, unbiased with noise on the output only, open loop.
        ``"hv"``: errors in variables (total least squares, SISO only) on channels scaled to
        equal power, for noise on input and output: consistent when both noises are white
        with the same signal-to-noise ratio. Bounds: those of H1 with the Hv residual
        (first order, not coverage-tested).
        ``"reference"``: closed-loop estimate through the reference, ``H = S_yr S_ur⁺``
        (the joint input-output / indirect estimate, Pintelon & Schoukens, 2012, ch. 2): unbiased
        under feedback when ``r`` is independent of the noise.
    level : float
        Confidence level of the bounds [1], in (0, 1).
    detrend : {"constant", "linear"} or False
        Trend removed from each window before the FFT.

    Returns
    -------
    NonparametricFRF

    Raises
    ------
    DataError
        NaN or inf (with the sample), lengths or record counts that differ, a record
        shorter than ``nperseg``, fewer than 2 windows in all, or not more equivalent
        averages than inputs; a reference with fewer channels than ``u``.
    ConfigError
        Unknown ``estimator``, ``"hv"`` with several inputs or outputs, a missing or
        unexpected ``reference``, bad ``nperseg``, ``noverlap``, ``fs`` or ``level``.
    """
    if estimator not in ESTIMATORS:
        raise ConfigError("estimator", f"must be one of {ESTIMATORS}, got {estimator!r}")
    if (reference is None) == (estimator == "reference"):
        raise ConfigError("reference", "a measured reference is needed by (and only used by) "
                          f"estimator='reference'; got estimator={estimator!r}")
    nperseg, noverlap = _check_windows(nperseg, noverlap)
    if not (np.isfinite(fs) and fs > 0):
        raise ConfigError("fs", f"must be a positive sample rate in Hz, got {fs!r}")
    if not 0.0 < level < 1.0:
        raise ConfigError("level", f"must lie in (0, 1), e.g. 0.95; got {level!r}")
    named = {"u": u, "y": y} | ({} if reference is None else {"reference": reference})
    records, widths = _records(named, nperseg)
    nu, ny = widths["u"], widths["y"]
    if estimator == "hv" and nu * ny > 1:
        raise ConfigError("estimator", f"'hv' is implemented for one input and one output; "
                          f"got {nu} input(s), {ny} output(s): use 'h1' or 'reference'")
    if reference is not None and widths["reference"] < nu:
        raise DataError("reference", f"has {widths['reference']} channel(s), fewer than the "
                        f"{nu} inputs: the estimate needs at least one reference per input")

    stft = ShortTimeFFT(_window(window, nperseg), nperseg - noverlap, fs,
                        fft_mode="onesided", scale_to="psd")
    spec, n_windows, n_avg = _pooled_spectra(stft, records, noverlap,
                                             None if detrend is False else detrend)
    if n_windows < 2 or n_avg <= nu:
        raise DataError("u", f"gives {n_windows} window(s) of {nperseg} samples "
                        f"({n_avg:.2f} equivalent averages); at least 2 and more than the "
                        f"{nu} input(s) are needed: lengthen the record or shorten nperseg")

    iu, iy = slice(0, nu), slice(nu, nu + ny)
    iz = iu if reference is None else slice(nu + ny, None)
    proj = np.linalg.pinv(spec[:, iz, iu])                      # P, shape (F, nu, nz)
    # Hᵀ, shape (F, nu, ny)
    frf_t = _total_least_squares(spec) if estimator == "hv" else proj @ spec[:, iz, iy]
    frf = np.swapaxes(frf_t, 1, 2)
    coherence = _multiple_coherence(spec, iz, iy)
    gain_var = np.einsum("fiz,fzw,fiw->fi", proj, spec[:, iz, iz], proj.conj()).real
    radius = _radius(spec, frf_t, iu, iy, gain_var, n_avg, nperseg, level)

    mag = np.abs(frf)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(mag > radius, radius / np.where(mag > 0, mag, 1.0), 1.0)
    return NonparametricFRF(
        frequency=stft.f,
        frf=frf,
        coherence=np.broadcast_to(coherence[:, :, None], frf.shape).copy(),
        n_averages=n_avg,
        magnitude_lower=np.maximum(mag - radius, 0.0),
        magnitude_upper=mag + radius,
        phase_halfwidth=np.where(ratio < 1.0, np.arcsin(ratio), np.pi),
        level=float(level),
        estimator=estimator,
    )


def coherent_band(est: NonparametricFRF, threshold: float) -> CoherentBand:
    """Frequencies where the squared coherence of an estimate reaches ``threshold``.

    Parameters
    ----------
    est : NonparametricFRF
    threshold : float
        Squared coherence [1] in [0, 1], e.g. 0.9 (noise power 10 % of the output's).

    Returns
    -------
    CoherentBand
        The mask (F, ny, nu) and, per element, the edges [Hz] of the longest contiguous
        run of coherent frequencies.
    """
    if not 0.0 <= threshold <= 1.0:
        raise ConfigError("threshold", f"squared coherence must lie in [0, 1], got {threshold}")
    mask = est.coherence >= threshold
    f_low = np.full(mask.shape[1:], np.nan)
    f_high = np.full(mask.shape[1:], np.nan)
    for idx in np.ndindex(*mask.shape[1:]):
        # run boundaries of the 0/1 sequence padded with zeros: starts at +1, ends at -1
        edges = np.diff(np.concatenate(([0], mask[(slice(None), *idx)].astype(int), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        if starts.size:
            k = int(np.argmax(ends - starts))
            f_low[idx], f_high[idx] = est.frequency[starts[k]], est.frequency[ends[k] - 1]
    return CoherentBand(mask, f_low, f_high)


def _window(window: str | tuple | np.ndarray, nperseg: int) -> np.ndarray:
    """Window samples (periodic, as :func:`scipy.signal.welch`)."""
    if isinstance(window, np.ndarray):
        if window.shape != (nperseg,):
            raise ConfigError("window", f"has shape {window.shape}; need ({nperseg},)")
        return window.astype(float)
    return get_window(window, nperseg)


def _check_windows(nperseg: object, noverlap: object) -> tuple[int, int]:
    """Validated ``nperseg`` and ``noverlap`` [samples] (default overlap: half a window)."""
    if isinstance(nperseg, bool) or not isinstance(nperseg, (int, np.integer)) or nperseg < 2:
        raise ConfigError("nperseg", f"must be an integer >= 2 samples, got {nperseg!r}")
    noverlap = nperseg // 2 if noverlap is None else noverlap
    if isinstance(noverlap, bool) or not isinstance(noverlap, (int, np.integer)) \
            or not 0 <= noverlap < nperseg:
        raise ConfigError("noverlap", f"must be an integer in [0, nperseg={nperseg}), got "
                          f"{noverlap!r}")
    return int(nperseg), int(noverlap)


def _records(named: dict, nperseg: int) -> tuple[list[np.ndarray], dict[str, int]]:
    """Validate the signals; return one (channels, N) array per record and channel counts."""
    lists = {}
    for name, x in named.items():
        many = isinstance(x, (list, tuple)) and len(x) > 0 and all(np.ndim(e) for e in x)
        lists[name] = [as_2d(e, f"{name}[{k}]") for k, e in enumerate(x)] if many \
            else [as_2d(x, name)]
        if len(lists[name]) != len(lists["u"]):
            raise DataError(name, f"holds {len(lists[name])} record(s) but u holds "
                            f"{len(lists['u'])}; pass the same records for every signal")
    widths = {name: arrs[0].shape[1] for name, arrs in lists.items()}
    records = []
    for k, u_k in enumerate(lists["u"]):
        for name, arrs in lists.items():
            arr, label = arrs[k], name if len(arrs) == 1 else f"{name}[{k}]"
            if arr.shape[1] != widths[name]:
                raise DataError(label, f"has {arr.shape[1]} channel(s), the first record "
                                f"{widths[name]}; every record needs the same channels")
            if arr.shape[0] != u_k.shape[0]:
                raise DataError(label, f"has {arr.shape[0]} samples but u has "
                                f"{u_k.shape[0]}; the signals must be sampled together")
            if arr.shape[0] < nperseg:
                raise DataError(label, f"has {arr.shape[0]} samples, fewer than "
                                f"nperseg={nperseg}: shorten nperseg or drop the record")
            check_finite(arr, label)
        records.append(np.concatenate([arrs[k] for arrs in lists.values()], axis=1).T)
    return records, widths


def _pooled_spectra(stft: ShortTimeFFT, records: Sequence[np.ndarray], noverlap: int,
                    detrend: str | None) -> tuple[np.ndarray, int, float]:
    """Cross-spectral matrix pooled over every whole window of every record.

    Returns ``S`` (F, C, C) with ``S[f, i, j] = mean(conj(Z_i) Z_j)`` (as
    :func:`scipy.signal.csd` of channel i with channel j), the number of windows and the
    equivalent number of averages.
    """
    total = np.zeros((stft.f.size, records[0].shape[0], records[0].shape[0]), complex)
    n_windows, n_avg = 0, 0.0
    for rec in records:
        k_rec = (rec.shape[1] - stft.m_num) // stft.hop + 1
        for p0 in range(0, k_rec, _SLICES_PER_BLOCK):
            # k_offset of half a window: slice p starts at sample p * hop, whole windows only
            z = stft.stft_detrend(rec, detrend, p0=p0, p1=min(p0 + _SLICES_PER_BLOCK, k_rec),
                                  k_offset=stft.m_num_mid, axis=-1)
            total += np.einsum("cfk,dfk->fcd", z.conj(), z)
        n_windows += k_rec
        n_avg += equivalent_averages(stft.win, stft.m_num, noverlap, k_rec)
    return total / n_windows, n_windows, n_avg


def _total_least_squares(spec: np.ndarray) -> np.ndarray:
    """SISO Hv: the eigenvector of the least eigenvalue of the (u, y) spectral matrix.

    The two channels are first scaled to equal total power, so the result does not depend
    on their units. Returns Hᵀ, shape (F, 1, 1).
    """
    scale = np.sqrt(spec[:, 1, 1].real.sum() / spec[:, 0, 0].real.sum())
    d = np.array([1.0, 1.0 / scale])
    _, vec = np.linalg.eigh(spec * d[:, None] * d[None, :])
    # the noise-free relation u x0 + (y/scale) x1 = 0 gives y = -scale x0 / x1 u
    return (-scale * vec[:, 0, 0] / vec[:, 1, 0])[:, None, None]


def _multiple_coherence(spec: np.ndarray, iz: slice, iy: slice) -> np.ndarray:
    """Squared multiple coherence of each output with the instruments, (F, ny), in [0, 1]."""
    s_zy = spec[:, iz, iy]
    explained = np.einsum("fza,fza->fa", s_zy.conj(), np.linalg.pinv(spec[:, iz, iz]) @ s_zy)
    power = np.einsum("faa->fa", spec[:, iy, iy]).real
    with np.errstate(divide="ignore", invalid="ignore"):
        coh = np.where(power > 0, explained.real / power, 0.0)
    return np.clip(coh, 0.0, 1.0)


def _radius(spec: np.ndarray, frf_t: np.ndarray, iu: slice, iy: slice,
            gain_var: np.ndarray, n_avg: float, nperseg: int, level: float) -> np.ndarray:
    """Radius of the confidence circle of every element, (F, ny, nu) [output/input unit]."""
    nu = frf_t.shape[1]
    s_yy = np.einsum("faa->fa", spec[:, iy, iy]).real
    cross = np.einsum("fia,fai->fa", frf_t, spec[:, iy, iu])
    fitted = np.einsum("fia,fij,fja->fa", frf_t.conj(), spec[:, iu, iu], frf_t).real
    residual = np.maximum(s_yy - 2.0 * cross.real + fitted, 0.0)   # Ĝ_vv per output
    dof = n_avg - nu
    # real DFT bins (DC; Nyquist for even nperseg) carry one degree of freedom, not two
    k = np.full(spec.shape[0], 2.0)
    k[0] = 1.0
    if nperseg % 2 == 0:
        k[-1] = 1.0
    quantile = stats.f.ppf(level, k, k * dof)
    r2 = quantile[:, None, None] * residual[:, :, None] * gain_var[:, None, :] / dof
    return np.sqrt(r2)
