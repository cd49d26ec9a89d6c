"""The kinds of all the clusters of one record: each judged, then against the others.

:func:`record_evidence` judges each cluster of a record's stabilization diagrams
(:func:`gbpipe.identify.mode_kinds.cluster_evidence`), then reads them together:

* a cluster whose band holds a lighter mode (another cluster called a ``mode``, of a
  narrower half-power band) and reads as a sinusoid is judged again against that mode's
  limit: the lighter mode's longer correlation makes the band's statistic scatter more
  than the cluster's own would;
* without a measured speed, the clusters that read as sinusoids give the record's own
  order-1 line (:func:`gbpipe.identify.harmonic_lines.order_one`), and the clusters on
  its lines are ``harmonic``.

docs/modal.md, "Criteria".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np

from gbpipe.identify.harmonic_lines import HarmonicBands, order_one
from gbpipe.identify.mode_kinds import Evidence, band_half_width, cluster_evidence

__all__ = ["Cluster", "PairingData", "record_evidence"]


class Cluster(NamedTuple):
    """One cluster to judge: its pairing (index), frequency [Hz], damping [1] and, for a
    cluster of a diagram other than the FRF's, ``frf_hz`` (:func:`cluster_evidence`)."""

    pairing: int
    frequency_hz: float
    damping: float
    frf_hz: np.ndarray | None = None


class PairingData(NamedTuple):
    """What the tests read of one pairing: its conditioned outputs (``y`` (N, ny), names,
    rate ``fs`` [Hz]), the highest coherence over its FRF elements [1] per frequency
    [Hz] of its nonparametric estimate, and the reference shaft's angle at the outputs'
    samples [rad] (None: no speed measured)."""

    y: np.ndarray
    names: Sequence[str]
    fs: float
    frequency: np.ndarray
    coherence: np.ndarray
    angle: np.ndarray | None = None


def record_evidence(clusters: Sequence[Cluster], data: Sequence[PairingData],
                    bands: HarmonicBands, orders: Sequence[float], resolution_hz: float,
                    coherence_min: float, n_harmonics: int, f_max: float, seed: int,
                    speeds: Mapping[str, tuple[float, float]] | None = None
                    ) -> tuple[list[Evidence], HarmonicBands]:
    """The evidence of every cluster of a record, and the order lines used.

    Each cluster is judged (:func:`cluster_evidence`); one that the PDF test read as a
    sinusoid with a narrower ``mode`` of its pairing in its band (:func:`_lighter_mode`)
    is judged again against that mode's limit, with Monte Carlo draws of its own (a
    generator per cluster from ``seed``: the other clusters' draws stay as they are).
    With a measured speed (``bands`` not empty) that is all. Without one, the clusters
    the PDF or damping test found to be sinusoids give the record's own order-1 line
    (:func:`order_one`), the user's ``orders`` scale from it, and any other cluster on
    those lines is relabelled ``harmonic``. A cluster off those lines that the PDF test
    called a line, whose peak does not drift, and whose half-power band ``2 zeta f`` is
    wider than every one of those lines' bands in its band (no line makes a peak that
    wide), is judged again with them, as with a measured speed (no angle): the line in
    its band, not the cluster, made its PDF a sinusoid's.

    Parameters
    ----------
    seed : int
        Seed of the Monte Carlo draws (the config's root ``seed``).
    speeds : mapping str -> (float, float), optional
        Speed signals no ``shaft_order`` places -> their shaft's frequency range [Hz]:
        candidates for order 1 (:func:`order_one`).
    """
    rng = np.random.default_rng(seed)

    def judge(k: int, lines: HarmonicBands, angle: np.ndarray | None,
              lighter: tuple[float, float] | None = None) -> Evidence:
        c, d = clusters[k], data[clusters[k].pairing]
        # a judgement against a lighter mode draws from a generator of its own
        draws = rng if lighter is None else np.random.default_rng((seed, 1, k))
        return cluster_evidence(c.frequency_hz, c.damping, list(d.y.T), d.names, d.fs,
                                d.frequency, d.coherence, resolution_hz, coherence_min,
                                lines, draws, angle, c.frf_hz, lighter)

    ev = [judge(k, bands, data[c.pairing].angle) for k, c in enumerate(clusters)]
    # a band that holds a lighter mode scatters as that mode's response does: a sinusoid
    # read there is judged again against that mode's limit
    light = [_lighter_mode(c, clusters, ev, resolution_hz) if e.sinusoid else None
             for c, e in zip(clusters, ev, strict=True)]
    for k, c in enumerate(clusters):
        if light[k] is not None:
            ev[k] = judge(k, bands, data[c.pairing].angle, light[k])
    if bands.source:
        return ev, bands
    lines = np.array([c.frequency_hz for c, e in zip(clusters, ev, strict=True)
                      if e.kind == "harmonic"])
    own = order_one(lines, orders, resolution_hz, n_harmonics, f_max, speeds)
    for k, c in enumerate(clusters):
        order = own.order_at(c.frequency_hz)
        if np.isfinite(order):
            if ev[k].kind != "harmonic":
                text = f"order {order:.4g} of {own.source}; " + ev[k].text.split("; ", 1)[1]
                ev[k] = ev[k]._replace(kind="harmonic", text=text)
            ev[k] = ev[k]._replace(line_order=order)
        elif (ev[k].kind == "harmonic" and ev[k].sinusoid and not ev[k].drifts
              and _wider_than_lines(c, own, resolution_hz)):
            ev[k] = judge(k, own, None, light[k])  # the record's own lines: no angle
    return ev, own


def _lighter_mode(c: Cluster, clusters: Sequence[Cluster], ev: Sequence[Evidence],
                  resolution_hz: float) -> tuple[float, float] | None:
    """Frequency [Hz] and damping [1] of the cluster of ``c``'s pairing called a ``mode``
    in ``c``'s band (:func:`cluster_evidence`) with the narrowest half-power band
    ``2 zeta f``, if narrower than ``c``'s; None for none."""
    f, bw = c.frequency_hz, c.damping * c.frequency_hz
    w = band_half_width(f, c.damping, resolution_hz)
    near = [(o.damping * o.frequency_hz, o.frequency_hz, o.damping)
            for o, e in zip(clusters, ev, strict=True)
            if o.pairing == c.pairing and e.kind == "mode"
            and abs(o.frequency_hz - f) <= w and o.damping * o.frequency_hz < bw]
    return min(near)[1:] if near else None


def _wider_than_lines(c: Cluster, bands: HarmonicBands, resolution_hz: float) -> bool:
    """Whether lines of ``bands`` lie in the cluster's band (:func:`cluster_evidence`) and
    its half-power band ``2 zeta f`` is wider than each of their bands (the widest peak
    a line can make: :meth:`~gbpipe.identify.harmonic_lines.HarmonicBands.widest`)."""
    f = c.frequency_hz
    widest = bands.widest(bands.overlapping(f, band_half_width(f, c.damping, resolution_hz)))
    return bool(2.0 * c.damping * f > widest)  # NaN (no line in the band): False
