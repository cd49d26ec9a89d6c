"""The stabilization diagrams of one pairing of a bench record, zoomed.

Two diagrams (:func:`diagrams`): the subspace one (``identify.stabilization.method``) on
the conditioned data and an LSCF one on their nonparametric FRF (every Welch line but DC,
up to Nyquist: :func:`_whole_band`). Both are fitted again on the data decimated further
(:func:`zoom_bands`) and each is read as one diagram joined over those bands
(:func:`join_bands`), each diagram's clusters below its band keeping their poles; the
identification rate's diagram alone sets the model order
(:class:`Diagram`). :func:`gbpipe.identify.record_modes` calls it; docs/modal.md, "What
the stage does" and "Zoomed diagrams".
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from gbpipe.identify.orders import order_windows
from gbpipe.identify.prepare import decimate
from gbpipe.identify.reference import Reference, nonparametric_reference
from gbpipe.sysid import (
    Stabilization,
    join_poles,
    lscf_stabilization,
    select_poles,
    stabilization_diagram,
    stabilize,
)

__all__ = ["Diagram", "diagrams", "join_bands", "order_range", "zoom_bands"]

log = logging.getLogger("gbpipe")


def order_range(bounds: Sequence[int], step: int) -> np.ndarray:
    """Model orders ``bounds[0], bounds[0] + step, ... <= bounds[1]`` (int array)."""
    return np.arange(int(bounds[0]), int(bounds[1]) + 1, int(step))


#: Share of a zoomed diagram's anti-aliasing pass band it reports; the rest is left to
#: the band above. At 0.8 a zoomed PBSID diagram put a lightly damped pole 1 Hz beside a
#: mesh line near its top and called it a mode (tests/identify/test_mode_kinds.py); 0.65
#: did not, and its recall over random chains was within 3 modes in 147 of 0.8's
#: (docs/modal.md, "Zoomed diagrams").
_TOP = 0.65


def zoom_bands(s: Mapping[str, Any], fs: float) -> list[tuple[int, float, float]]:
    """The bands of a record's diagrams: (decimation from ``fs``, lower, upper edge [Hz]).

    The first is the identification rate's own diagram, above the second's upper edge;
    each next one is the data decimated ``identify.stabilization.zoom`` times more, up to
    :data:`_TOP` of its anti-aliasing pass band (``identify.lowpass`` of its Nyquist),
    while that holds an octave above ``identify.frf.f_min`` (the band below it reports
    nothing). ``zoom`` 1: one band.
    """
    zoom, cut = int(s["stabilization"]["zoom"]), float(s["lowpass"])
    bands = [(1, 0.0, np.inf)]
    q = zoom
    while zoom > 1 and (top := _TOP * cut * 0.5 * fs / q) >= 2 * float(s["frf"]["f_min"]):
        bands[-1] = (bands[-1][0], top, bands[-1][2])
        bands.append((q, 0.0, top))
        q *= zoom
    return bands


def diagrams(u: np.ndarray, y: np.ndarray, r: np.ndarray | None, fs: float,
             s: Mapping[str, Any], name: str) -> dict[str, Diagram | str]:
    """Both diagrams of one pairing, each joined over the zoom bands (:func:`zoom_bands`).

    Parameters
    ----------
    u, y : ndarray, shape (n, inputs) and (n, outputs)
        The pairing's conditioned inputs and outputs at ``fs``.
    r : ndarray or None
        Its conditioned reference (set-point) signals, or None.
    fs : float
        Identification rate [Hz].
    s : mapping
        The validated ``identify`` section.
    name : str
        Pairing name (log lines).

    Returns
    -------
    dict
        Per method (the subspace method, ``lscf``): a :class:`Diagram`, or the reason
        its diagram at the identification rate failed (status), not raised. A zoomed band
        that fails (a record too short for its windows) is left out with the bands below
        it, and the log says so.
    """
    st = s["stabilization"]
    crit = {k: st[k] for k in ("frequency_tolerance", "damping_tolerance", "mac_min")}
    orders = order_range(st["orders"], st["step"])
    # the windows of the identify stage, lengthened where the highest order needs more
    # block rows than they give: a diagram is read off one projection, so its windows
    # must hold its largest order (the identify stage lengthens them alike)
    w = order_windows(s, int(orders[-1]), y.shape[1])
    # (the estimator's own defaults otherwise: on the bench example, PBSID with the
    # identify stage's estimated feedthrough held no cluster at its 62 Hz mode)
    windows = (w if st["method"] == "pbsid" else
               {"past": w["past"], "horizon": w["future"]})
    lscf_orders = order_range(st["lscf_orders"], 1)
    out: dict[str, Diagram | str] = {}
    fitted: dict[str, list[tuple[Stabilization, int, float, float]]] = {}
    for b, (q, low, high) in enumerate(zoom_bands(s, fs)):
        ub, yb, rb = ((x if x is None or q == 1 else decimate(x, fs, fs / q, s["lowpass"]))
                      for x in (u, y, r))
        for method in (st["method"], "lscf"):
            if len(fitted.get(method, [])) < b:
                continue  # the band above failed: no lower band
            try:
                d = (_lscf(ub, yb, rb, fs / q, lscf_orders, s, crit) if method == "lscf" else
                     stabilization_diagram(ub, yb, q / fs, orders, method,
                                           max_damping=s["zeta_max"], **windows, **crit))
                fitted.setdefault(method, []).append((d, q, low, high))
            except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
                if not b:
                    out[method] = f"failed: {type(exc).__name__}: {exc}"
                else:
                    log.info("%s %s: the band below %.3g Hz (%g Hz rate) is left out: "
                             "%s: %s", name, method, high, fs / q, type(exc).__name__, exc)
    for method, res in fitted.items():
        out[method] = join_bands(res, method, crit)
    return out


def join_bands(res: Sequence[tuple[Stabilization, int, float, float]], method: str,
               crit: Mapping[str, float]) -> Diagram:
    """One method's diagrams over the zoom bands, read as one diagram.

    Each diagram keeps its band and every cluster it found below it, from the
    identification rate down: a diagram's estimate stands where it has one, and the
    diagrams below add their poles elsewhere in their bands. A more decimated diagram
    spends its orders on fewer modes, but it can lose a low mode that the diagram above
    it held (seed 2 of ``benchmarks/modal_selection.py``, case 28: its 5.1 Hz mode is a
    cluster of 21 orders at 250 Hz, scattered over 4.8-5.4 Hz at 125 Hz). Where both hold
    one, the less decimated estimate stands, as the identification rate's does: the
    band's own diagram first lost most of the gain (docs/modal.md, "A zoomed diagram's
    clusters below its band"). A diagram's clusters above its band, near its
    anti-aliasing edge, keep nothing.

    Parameters
    ----------
    res : sequence of (Stabilization, int, float, float)
        Per band, from the identification rate down: its diagram, decimation and band
        edges [Hz] (:func:`zoom_bands`).
    method : str
        Name of the joined diagram.
    crit : mapping
        The stability criteria (``frequency_tolerance``, ``damping_tolerance``,
        ``mac_min``) of :func:`gbpipe.sysid.stabilize`.

    Returns
    -------
    Diagram
    """
    own = res[0][0]
    # the bands kept (the lowest down to 0 Hz), each with the decimation it was fitted at
    bands = [(q, 0.0 if k == len(res) - 1 else low, high)
             for k, (_, q, low, high) in enumerate(res)]
    claims = [np.array([m.frequency_hz for m in d.clusters if m.frequency_hz < high])
              for (d, *_), (_, _, high) in zip(res, bands, strict=True)]
    if len(res) == 1:
        return Diagram(own, own, bands, claims)
    tol = _NEAR * float(crit["frequency_tolerance"])
    parts = [select_poles(d.poles, partial(_believed, band=band[1:], own=claims[k],
                                           taken=np.concatenate([[], *claims[:k]]), tol=tol))
             for k, ((d, *_), band) in enumerate(zip(res, bands, strict=True))]
    return Diagram(stabilize(own.orders, join_poles(parts), method, **crit), own, bands,
                   claims)


@dataclass
class Diagram:
    """One method's diagram of one pairing: ``joined`` over the zoom bands (the modes),
    ``own`` at the identification rate alone (the model order), ``bands`` kept:
    (decimation, lower, upper edge [Hz]), and per band the frequencies [Hz] of its
    diagram's clusters not above its band, whose poles it keeps (``claims``)."""

    joined: Stabilization
    own: Stabilization
    bands: list[tuple[int, float, float]]
    claims: list[np.ndarray]

    def decimation(self, frequency_hz: float, tol: float) -> int:
        """Decimation of the diagram a cluster of the joined one at ``frequency_hz`` was
        read from (as :func:`_believed` kept its poles)."""
        f = np.array([frequency_hz])
        for (q, *_), claimed in zip(self.bands, self.claims, strict=True):
            if _near(f, claimed, _NEAR * tol)[0]:
                return q
        return next(q for q, low, high in self.bands if low <= frequency_hz < high)


#: Relative distance (in frequency tolerances) within which a diagram's cluster keeps its
#: poles in the joined diagram.
_NEAR = 2.0


def _near(f: np.ndarray, own: np.ndarray, tol: float) -> np.ndarray:
    # which frequencies [Hz] lie within the relative tolerance of one of the clusters own
    return (np.abs(f[:, None] - own[None, :]) <= tol * own[None, :]).any(axis=1)


def _believed(f: np.ndarray, band: tuple[float, float], own: np.ndarray,
              taken: np.ndarray, tol: float) -> np.ndarray:
    # which poles [Hz] of a diagram the joined one keeps: in its band or near its own
    # clusters below its top (above it the diagram above keeps its own poles: one
    # diagram's per frequency), but not near those the diagrams above it kept
    inside = (f >= band[0]) & (f < band[1])
    return (inside | (_near(f, own, tol) & (f < band[1]))) & ~_near(f, taken, tol)


def _lscf(u: np.ndarray, y: np.ndarray, r: np.ndarray | None, fs: float,
          orders: np.ndarray, s: Mapping[str, Any], crit: Mapping[str, float]
          ) -> Stabilization:
    ref = _whole_band(u, y, fs, s, r)
    return lscf_stabilization(ref.frequency, ref.frf, orders, 1.0 / fs,
                              weights=_lscf_weights(ref), max_damping=s["zeta_max"], **crit)


def _whole_band(u: np.ndarray, y: np.ndarray, fs: float, s: Mapping[str, Any],
                r: np.ndarray | None) -> Reference:
    """The nonparametric FRF the LSCF diagram fits: every Welch line but DC, to Nyquist.

    A frequency-domain fit leaves its polynomials free outside the fitted lines, and
    poles gather at the edges of a fitted band (PolyMAX practice: fit a band wider than
    the one reported). On the z-domain basis the lines from the first above DC to Nyquist
    constrain the whole unit circle (its lower half is the conjugate), so no edge is left
    inside the reported band ``frf.f_min``-``f_max`` and no margin has to be chosen; the
    lines above the anti-aliasing pass band are incoherent and weigh little
    (:func:`_lscf_weights`). H1 and the reference estimate divide the decimation filter
    out (it acts on input and output alike). DC is left out: the operating point is
    removed, so the estimate there is noise over noise.
    """
    resolution = 1.0 / float(s["nonparametric"]["segment"])
    whole = {**s, "frf": {**s["frf"], "f_min": 0.5 * resolution, "f_max": 0.5 * fs}}
    return nonparametric_reference(u, y, fs, whole, r)


def _lscf_weights(ref: Reference) -> np.ndarray:
    # each line of each output weighted by the inverse standard deviation of the estimate
    # (from its 95 % magnitude bounds, averaged over the inputs): the noisy, incoherent
    # lines count little, and outputs in different units count alike
    sd = np.nanmean(ref.upper - ref.lower, axis=2) / (2 * 1.96)
    return np.where(np.isfinite(sd) & (sd > 0), 1.0 / np.where(sd > 0, sd, 1.0), 0.0)
