"""The design step's figure: predicted identifiable band of each pairing and test beside
the band the identification achieved, and the predicted FRF error against frequency.

Reads the ``design`` stage's datasets (:func:`gbpipe.identify.predict`) and, when they
exist, the achieved match bandwidths of the ``identify`` stage. See docs/design.md.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import new, save

__all__ = ["fig_design", "design_numbers"]


def design_numbers(designs: Mapping[str, xr.Dataset],
                   achieved: Mapping[tuple[str, str], float] | None = None
                   ) -> dict[str, str]:
    """Caption numbers: predicted (and achieved) band per test and pairing.

    Parameters
    ----------
    designs : mapping
        Test label -> design dataset.
    achieved : mapping, optional
        (test label, pairing) -> achieved match bandwidth [Hz].

    Returns
    -------
    dict
        ``"<test>, <pairing>"`` -> ``"predicted P Hz"`` (``", achieved A Hz (A/P)"``).
    """
    achieved = achieved or {}
    out = {}
    for label, ds in designs.items():
        for name, hz in zip(ds.pairing.values, ds.predicted_hz.values, strict=True):
            text = f"predicted {hz:.0f} Hz"
            got = achieved.get((label, str(name)))
            if got is not None and np.isfinite(got):
                ratio = f" ({got / hz:.2f} x)" if hz > 0 else ""
                text += f", achieved {got:.0f} Hz{ratio}"
            out[f"{label}, {name}"] = text
    return out


def _bands(ax: Any, designs: Mapping[str, xr.Dataset],
           achieved: Mapping[tuple[str, str], float]) -> None:
    """Horizontal bars: predicted band per pairing (rows) and test (colours); achieved
    bands as black ticks on their bars."""
    labels = list(designs)
    pairings = list(dict.fromkeys(str(p) for ds in designs.values() for p in ds.pairing.values))
    height = 0.8 / max(1, len(labels))
    for j, label in enumerate(labels):
        ds = designs[label]
        y = np.array([pairings.index(str(p)) for p in ds.pairing.values]) + j * height
        ax.barh(y, ds.predicted_hz.values, height=height, label=label, alpha=0.8)
        got = np.array([achieved.get((label, str(p)), np.nan) for p in ds.pairing.values])
        ax.plot(got, y, "k|", markersize=8, mew=2,
                label="achieved" if j == 0 and np.isfinite(got).any() else None)
    ax.set_yticks(np.arange(len(pairings)) + 0.4 - height / 2, pairings)
    ax.invert_yaxis()
    ax.set_xlabel("band within the tolerance from f_min [Hz]")
    ax.set_title("Predicted (bars) and achieved (|) band")
    ax.legend(loc="lower right", fontsize=6)


def _errors(ax: Any, ds: xr.Dataset, label: str) -> None:
    """Predicted 95 % error bound (worst element) of every pairing vs frequency."""
    f = ds.frequency.values
    tol = float(ds.attrs.get("tolerance_db", 1.0))
    for name in ds.pairing.values:
        e = ds.predicted_error_db.sel(pairing=name).values.reshape(f.size, -1)
        e = e[:, np.isfinite(e).any(axis=0) | np.isinf(e).any(axis=0)]  # drop NaN padding
        worst = np.max(np.nan_to_num(e, nan=1e3, posinf=1e3), axis=1)
        ax.loglog(f, np.clip(worst, 1e-3, 1e3), lw=1, label=str(name))
    ax.axhline(tol, color="k", ls="--", lw=1, label=f"tolerance {tol:g} dB")
    ax.set_ylim(1e-3, 1e2)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("predicted 95 % FRF error [dB]")
    ax.set_title(f"Predicted error, {label}")
    ax.legend(fontsize=6, ncol=2)


def fig_design(designs: Mapping[str, xr.Dataset], stem: str | os.PathLike,
               caption: str | os.PathLike,
               achieved: Mapping[tuple[str, str], float] | None = None,
               detail: str | None = None, version: str | None = None) -> dict[str, str]:
    """Draw the design figure and write its caption.

    Parameters
    ----------
    designs : mapping
        Test label (e.g. ``"ms_torque tapered"``) -> design dataset.
    stem : path-like
        Figure path without extension (every format of
        :func:`~gbpipe.figures.style.save`).
    caption : path-like
        Caption ``.rst`` file.
    achieved : mapping, optional
        (test label, pairing) -> achieved match bandwidth [Hz].
    detail : str, optional
        Test label whose error curves the right panel shows; default the one with the
        widest predicted band.
    version : str, optional
        The data version the designs (one version each) and the achieved bands are of,
        for the caption.

    Returns
    -------
    dict
        The caption numbers (:func:`design_numbers`).
    """
    achieved = dict(achieved or {})
    if detail not in designs:
        detail = max(designs, key=lambda k: float(designs[k].predicted_hz.max()))
    fig, (ax_b, ax_e) = new(1, 2, figsize=(11.0, 4.6))
    _bands(ax_b, designs, achieved)
    _errors(ax_e, designs[detail], detail)
    save(fig, stem)
    numbers = design_numbers(designs, achieved)
    write_caption(caption, "Predicted identifiable band", "extension (design step)",
                  (f"Data version {version}. " if version else "")
                  + "Left: per pairing and test, the band from identify.frf.f_min up to which "
                  "the predicted 95 % FRF magnitude error of a direct closed-loop estimate "
                  "(Ljung 1999, eq. 9.62) stays within identify.tolerance_db, from the bench "
                  "model, the set-points, the noise spectra and the gear excitation the "
                  "version keeps; black ticks: the match "
                  "bandwidth identification achieved. Right: the predicted error against "
                  f"frequency for {detail} (worst element of each pairing).", numbers)
    return numbers
