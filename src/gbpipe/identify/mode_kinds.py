"""Modes, order lines and noise poles told apart, from the signals themselves.

A stable cluster of a stabilization diagram is one of three things:

``harmonic``
    An order line: a persistent sinusoid the fit explains with a lightly damped pole.
    Three tests say so, each needing no tachometer:

    * the **speed**: the cluster lies on an order line of a measured speed
      (:mod:`gbpipe.identify.harmonic_lines`), or of the record's own order-1 line
      (:func:`gbpipe.identify.harmonic_lines.order_one`, placed by
      :func:`gbpipe.identify.record_kinds.record_evidence`). With a measured speed the line
      itself is measured too (:func:`gbpipe.identify.band_signal.line_share`): the
      cluster is a line when the upper bound of the lines' share of its band's power
      reaches ``LINE_SHARE``, or one of the tests below calls it a line, or its band is
      not coherent. Otherwise it is the mode the line crosses (a line explains a band it
      dominates; a mode's random response that holds most of the band is the mode's,
      whatever line passes). A coherent cluster whose half-power band ``2 zeta f`` is
      wider than the whole band of the measured line on it
      (:meth:`~gbpipe.identify.harmonic_lines.HarmonicBands.widest`) is the mode the line
      crosses whatever these tests say: they see the line, and no line makes a peak that
      wide. A cluster of another diagram on a line is a mode only where
      the FRF's own diagram (LSCF) holds a cluster or candidate in its band: the FRF
      from the measured input averages out what that input does not drive, while a
      subspace fit models the whole output, a line under the band's noise included;
    * the **PDF** of the response in the cluster's band (Brincker, Andersen & Møller,
      "Identification of harmonics in operational modal analysis", IMAC 2000; Jacobs et
      al., "Harmonic detection in OMA", ISMA 2008): the band-passed response of a mode
      driven by random forces is Gaussian, kurtosis 3; a sinusoid's is 1.5. The
      statistic is the envelope form ``1.5 E|z|^4 / (E|z|^2)^2`` of the complex
      band signal ``z``, which equals the kurtosis of the real band signal for any
      narrow-band process of uniform phase. Its limit
      (:func:`gbpipe.identify.band_kurtosis.kurtosis_limit`) is the ``ALPHA`` quantile
      of that statistic under the hypothesis "a mode of the cluster's frequency and
      damping, driven by white noise, seen through the same band filter over the same
      duration": the sampling spread for the band's number of independent samples,
      drawn by Monte Carlo on the band's own correlation, not a tuned number. A band
      that reads as a sinusoid is read again through steeper filters: where it keeps
      under half its power, a strong line outside the band held it
      (:func:`gbpipe.identify.band_kurtosis.band_statistic`). The sinusoid is the pole's
      only where the band signal's spectrum
      (:func:`gbpipe.identify.band_signal.band_spectrum`) within one frequency line of
      the pole, ``f ± 1 / segment``, reaches half its strongest peak: a line's pole lies
      on the line (anywhere on its sweep), and a line further off is another's.
      A band that holds a lighter mode is judged against that mode's limit
      (:mod:`gbpipe.identify.record_kinds`);
    * the **drift**: a line follows its shaft's speed, so the peak near the cluster
      moves with time along a monotonic track (a run-up, a slow drift: the line sweeps
      through the band, its PDF there bursty); a mode's peak jitters at random.
      Spearman's rank correlation of each Welch segment's peak frequency with time
      (:func:`gbpipe.identify.peak_drift.peak_drift`), p below ``ALPHA``, on a track
      that comes within a frequency line of the pole (widened by its median step; one
      that keeps away follows another peak, or jumps between two), searched in the
      cluster's band, at least
      ``3 / segment`` on each side: an unresolved pole (``2 zeta f < 1 / segment``, as a
      line's) is located within one frequency line, the Hann main lobe spans
      ``2 / segment`` on each side, and the fit puts a swept line's pole anywhere on its
      sweep (within the pole's own band the line's peak sits at the edge, a flat track).
      A stationary response (modes, noise) has no trend in the wider band;
    * the **damping**: a half-power bandwidth ``2 ζ f`` narrower than the record's
      frequency resolution ``1 / T`` (a decay longer than the record) cannot be told from
      a line: ``ζ < 1 / (2 f T)``.
``spurious``
    A pole fitted to noise: no frequency line of the nonparametric estimate within the
    cluster's band reaches ``identify.nonparametric.coherence_min`` (the coherence the
    identify stage trusts). Across repeats (:mod:`gbpipe.identify.mode_groups`): a
    cluster found in fewer than half the records of its group.
``mode``
    Everything else.

docs/modal.md, "Criteria".
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import stats

from gbpipe.identify.band_kurtosis import band_statistic
from gbpipe.identify.band_signal import line_share
from gbpipe.identify.harmonic_lines import HarmonicBands
from gbpipe.identify.peak_drift import peak_drift

__all__ = ["KINDS", "ALPHA", "Evidence", "band_half_width", "resolvable_damping",
           "cluster_evidence", "LINE_SHARE"]

#: The kinds of a cluster.
KINDS = ("mode", "harmonic", "spurious")
#: False-alarm probability of the PDF test: the chance that a true mode is called a line
#: (per output; divided among the outputs tested, Bonferroni).
ALPHA = 1e-3
#: Share of a cluster's band power [1] from which the order lines measured in it, not the
#: mode they cross, are what the cluster fits (the bound of the share is compared).
LINE_SHARE = 0.5


class Evidence(NamedTuple):
    """What the data say of one cluster.

    Attributes
    ----------
    kind : str
        ``mode``, ``harmonic`` or ``spurious`` (:data:`KINDS`).
    text : str
        Why, in words.
    kurtosis : float
        Band kurtosis of the output lowest against its limit [1] (sinusoid 1.5, Gaussian
        3), of those whose sinusoid is the pole's where any is.
    kurtosis_limit : float
        Its limit under the mode hypothesis for that output [1].
    coherence : float
        Highest coherence of the estimate within the cluster's band [1].
    line_order : float
        Order of the line the cluster lies on [1]; NaN for none.
    drifts : bool
        Whether the peak near the cluster drifts with time (the drift test's line).
    sinusoid : bool
        Whether the PDF test read the pole as a sinusoid (the test's line).
    """

    kind: str
    text: str
    kurtosis: float
    kurtosis_limit: float
    coherence: float
    line_order: float
    drifts: bool
    sinusoid: bool


def band_half_width(frequency_hz: float, damping: float, resolution_hz: float) -> float:
    """Half-width [Hz] of a cluster's band: its half-power band ``2 zeta f`` twice over, at
    least one frequency line ``resolution_hz`` of the estimate on each side (a line cannot
    be located better than that)."""
    return max(resolution_hz, 2.0 * damping * frequency_hz)


def resolvable_damping(frequency_hz: float, duration_s: float) -> float:
    """Smallest damping ratio a record of ``duration_s`` [s] resolves at ``frequency_hz``
    [Hz]: half-power bandwidth ``2 ζ f`` equal to the resolution ``1 / T`` [1]."""
    return 1.0 / (2.0 * frequency_hz * duration_s)


def cluster_evidence(frequency_hz: float, damping: float, outputs: Sequence[np.ndarray],
                     names: Sequence[str], fs: float, coherence_f: np.ndarray,
                     coherence: np.ndarray, resolution_hz: float, coherence_min: float,
                     bands: HarmonicBands, rng: np.random.Generator,
                     angle: np.ndarray | None = None, frf_hz: np.ndarray | None = None,
                     lighter: tuple[float, float] | None = None) -> Evidence:
    """The kind of one cluster and why (module docstring).

    Parameters
    ----------
    frequency_hz, damping : float
        The cluster [Hz], [1].
    outputs : sequence of ndarray
        The pairing's conditioned output signals, sampled at ``fs`` [Hz].
    names : sequence of str
        Their names (for the evidence).
    coherence_f, coherence : ndarray
        Frequencies [Hz] of the nonparametric estimate and its highest coherence over the
        FRF elements at each [1].
    resolution_hz : float
        Frequency resolution of the estimate [Hz].
    coherence_min : float
        ``identify.nonparametric.coherence_min`` [1].
    bands : HarmonicBands
        The order lines of a measured speed (empty without one).
    rng : numpy.random.Generator
        For the Monte Carlo draws of the kurtosis limit.
    angle : ndarray, optional
        The reference shaft's angle at the outputs' samples [rad]
        (:func:`gbpipe.identify.harmonic_lines.reference_angle`): a cluster on an order
        line is then a line only where the line holds its band
        (:func:`gbpipe.identify.band_signal.line_share`) or its pole is wider than the
        line's band (:meth:`~gbpipe.identify.harmonic_lines.HarmonicBands.widest`: the
        speed range is measured); without it every cluster on a line is one.
    frf_hz : ndarray, optional
        Frequencies [Hz] of the clusters and candidates of the FRF's own diagram (LSCF)
        of the pairing, for a cluster of another diagram: on an order line, one with
        none of them in its band is the line's (module docstring). None: not asked.
    lighter : tuple of float, optional
        Frequency [Hz] and damping [1] of a lighter mode in the cluster's band: the PDF
        test's hypothesis is then that mode's half-power bandwidth, whose longer
        correlation makes the band's statistic scatter more
        (:func:`gbpipe.identify.record_kinds.record_evidence`).
        None: the cluster's own.
    """
    f, zeta = float(frequency_hz), float(damping)
    outputs = [np.asarray(x, float) for x in outputs]
    w = band_half_width(f, zeta, resolution_hz)
    duration = outputs[0].size / fs
    zeta_res = resolvable_damping(f, duration)
    # the hypothesis' half-power bandwidth: the cluster's, or a lighter mode's in its band
    zeta_null = zeta if lighter is None else lighter[1] * lighter[0] / f
    null = ("this damping" if lighter is None else
            f"the lighter mode at {lighter[0]:.1f} Hz (damping {lighter[1]:.4f}) in the band")
    alpha = ALPHA / len(outputs)
    drift, drift_at, passes = None, "", False
    # the drift test's band: the cluster's, at least the Hann main lobe about the pole's
    # located frequency (module docstring)
    wt = max(w, 3.0 * resolution_hz)
    power = []  # of each output's band signal
    leaks = []
    check_rng = rng.spawn(1)[0]
    # a band's sinusoid is the pole's where the band's spectrum within one frequency line
    # of the pole reaches half its strongest peak: a line's pole lies on the line (within
    # its sweep), so a line further off is another's, however wide the pole
    readings, beside = [], []  # (kurtosis - limit, kurtosis, limit, output, at the pole)
    for x, name in zip(outputs, names, strict=True):
        read = band_statistic(x, fs, f, max(zeta_null, zeta_res), w, alpha, rng, check_rng,
                              1.0 / resolution_hz)
        power.append(read.power)
        if read.note:
            leaks.append(f"{name}: {read.note}")
        at = False
        if read.spectrum is not None:
            offset, psd = read.spectrum
            share = float(np.max(psd[np.abs(offset) <= resolution_hz], initial=0.0) / np.max(psd))
            at = share >= 0.5
            if not at:
                beside.append(f"{name}'s spectrum within a frequency line of the pole "
                              f"({f - resolution_hz:.1f}-{f + resolution_hz:.1f} Hz) "
                              f"reaches {share:.3f} of its strongest peak "
                              f"({f + offset[np.argmax(psd)]:.1f} Hz), under half: a peak "
                              "beside the pole (a line's or another mode's)")
        readings.append((read.kurtosis - read.limit, read.kurtosis, read.limit, name, at))
        d = peak_drift(x, fs, f, wt, 1.0 / resolution_hz)
        # the track must pass the cluster: one beside it is a line beside the cluster
        on = bool(d.gap_hz <= resolution_hz + d.step_hz)  # NaN: no track
        if drift is None or (on and (not passes or d.p < drift.p)):
            drift, drift_at, passes = d, name, on
    # the reading reported: the most sinusoid-like, of those at the pole where any is
    at_pole = any(r[4] for r in readings)
    kurt, limit, worst = np.inf, np.nan, ""
    for diff, k, lim, name, at in readings:
        if (at or not at_pole) and diff < kurt - (limit if np.isfinite(limit) else 0.0):
            kurt, limit, worst = k, lim, name
    near = np.abs(coherence_f - f) <= w
    coh = float(np.max(coherence[near])) if near.any() else float(
        coherence[np.argmin(np.abs(coherence_f - f))])
    order = bands.order_at(f)
    band = f"{f - w:.1f}-{f + w:.1f} Hz"
    track_band = f"{f - wt:.1f}-{f + wt:.1f} Hz"
    # a known order line inside the band makes its PDF (and its peak track, in the wider
    # band) a line's whatever the cluster: there the speed decides, not the PDF (a mode
    # beside a line stays a mode)
    crossed = bands.order[bands.overlapping(f, w)]
    pdf_test = np.isfinite(order) or not crossed.size
    drift_test = np.isfinite(order) or not np.any(bands.overlapping(f, wt))
    facts = [f"kurtosis {kurt:.2f} in {band} of {worst} (sinusoid 1.5, Gaussian 3; a mode "
             f"of {null} gives >= {limit:.2f} with {100 * (1 - alpha):.2f} %)",
             f"peak frequency vs time in {track_band} of {drift_at}: Spearman "
             f"{drift.rho:.2f}, p {drift.p:.1e} over {drift.n} segments, track "
             f"{drift.low_hz:.1f}-{drift.high_hz:.1f} Hz"
             + ("" if passes else " (no track)"
                if not np.isfinite(drift.gap_hz) else f" (does not pass the cluster: "
                f"{drift.gap_hz:.2f} Hz off at the nearest, over "
                f"{resolution_hz + drift.step_hz:.2f} Hz: a peak beside it)"),
             *leaks, *([] if at_pole else beside),
             f"damping {zeta:.4f} (the record resolves >= {zeta_res:.5f})",
             *([] if pdf_test else [f"the band holds order line(s) "
                                    f"{', '.join(f'{k:.4g}' for k in crossed)}: the PDF "
                                    "test does not decide"]),
             f"coherence <= {coh:.2f} in {band}"]
    sinusoid = at_pole and pdf_test
    drifts = passes and drift.p < alpha and drift_test
    share = bound = np.nan
    if np.isfinite(order) and angle is not None:
        # every measured line whose band holds the cluster (bands overlap where the speed
        # range is wide or a mesh order meets a shaft harmonic)
        lines = bands.order[bands.inside(f)]
        shares = [line_share(x - np.mean(x), fs, angle, lines,
                             1.0 / resolution_hz, p, stats.norm.isf(alpha))
                  for x, p in zip(outputs, power, strict=True)]
        named = (f"the line{'s' if lines.size > 1 else ''} of order "
                 f"{', '.join(f'{k:.4g}' for k in lines)} of {bands.source}")
        if any(np.isfinite(r.bound) for r in shares):
            share, bound = np.nanmax(shares, axis=0)
            facts.insert(0, f"{named} {'have' if lines.size > 1 else 'has'} {share:.2f} "
                            f"times the power in {band} (at most {bound:.2f} with "
                            f"{100 * (1 - alpha):.2f} %; above 1: wider than the band)")
        else:  # held, as without an angle
            facts.insert(0, f"{named} not measured (under two segments with an angle)")
    held = not bound < LINE_SHARE  # NaN (no angle): the line is taken to hold its band
    # a pole wider than any peak the line can make is a mode's; the line's PDF, drift and
    # share are the line's, not the pole's (the line's own pole is another, narrow). Only
    # a measured speed bounds the line's width: the record's own line has no speed range
    # (wider than two frequency lines, so also resolved: 2 zeta f > 2 / segment > 1 / T)
    width = bands.widest(bands.inside(f))
    # the FRF averages out what the measured input does not drive (an order line): a
    # pole of the output's fit that the FRF's diagram does not hold is not a mode of it
    in_frf = frf_hz is None or bool(np.any(np.abs(np.asarray(frf_hz) - f) <= w))
    if not in_frf and np.isfinite(order):
        facts.insert(0, f"the FRF's diagram (LSCF) holds no pole in {band}")
    crossing = (angle is not None and bool(2.0 * zeta * f > width)  # NaN: on no line
                and coh >= coherence_min and in_frf)
    if crossing:
        on = ", ".join(f"{k:.4g}" for k in bands.order[bands.inside(f)])
        facts.insert(0, f"half-power band 2 zeta f = {2 * zeta * f:.2f} Hz, wider than the "
                        f"{width:.2f} Hz band of the line(s) on it")
        kind, why = "mode", (f"a mode that order(s) {on} of {bands.source} cross: its pole "
                             "is wider than any peak of the line")
    elif np.isfinite(order) and (held or sinusoid or drifts or zeta < zeta_res
                                 or coh < coherence_min or not in_frf):
        kind, why = "harmonic", f"order {order:.4g} of {bands.source}"
    elif zeta < zeta_res:
        kind, why = "harmonic", (f"damping {zeta:.5f} below the record's resolution "
                                 f"{zeta_res:.5f} (decays slower than the {duration:.0f} s "
                                 "record)")
    elif sinusoid:
        kind, why = "harmonic", f"kurtosis {kurt:.2f} below {limit:.2f} (sinusoid)"
    elif drifts:
        kind, why = "harmonic", (f"its peak drifts with time (Spearman {drift.rho:.2f}, p "
                                 f"{drift.p:.1e} < {alpha:.1e}): a line following a shaft's "
                                 "speed")
    elif coh < coherence_min:
        kind, why = "spurious", (f"coherence {coh:.2f} below coherence_min "
                                 f"{coherence_min:g} in {band} (noise fitted)")
    elif np.isfinite(order):
        kind, why = "mode", (f"a mode that order {order:.4g} of {bands.source} crosses: the "
                             f"line has under {LINE_SHARE:g} times the power in its band, "
                             + ("which no sinusoid dominates, resolved and coherent"
                                if not kurt < limit
                                else "which is resolved and coherent (a peak beside the "
                                "pole sets its PDF)"))
    else:
        # the test is one-sided (a sinusoid's kurtosis is low): at or above the limit no
        # sinusoid dominates the band, Gaussian or heavier-tailed (a transient excitation)
        no_line = pdf_test and not kurt < limit  # else a line in the band sets the PDF
        kind, why = "mode", ("no sinusoid dominates its band, resolved, coherent" if no_line else
                             "resolved and coherent (the line in its band sets its PDF)") + (
            f", on no order line of {bands.source}" if bands.source else "")
    return Evidence(kind, f"{why}; " + "; ".join(facts), kurt, limit, coh, order,
                    bool(drifts), bool(sinusoid))
