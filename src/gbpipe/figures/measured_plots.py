"""Figure of a measured record's identification: subspace models against the data.

For a bench record there is no true model. Each pairing's panel shows the nonparametric
FRF of the data with its 95 % band, shaded only inside its coherent band (where it is
trusted), and the subspace models of every method and data version drawn over it; a
lower panel shows the coherence and the threshold that bounds the band.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import db, new, save

__all__ = ["measured_identification_figure"]

_COLORS = {"pbsid": "C0", "moesp": "C1", "n4sid": "C2"}
_STYLES = {"raw": "--", "tsa": ":"}


def measured_identification_figure(datasets: Sequence[xr.Dataset], record: str,
                                   coherence_min: float,
                                   out: Mapping[str, str | os.PathLike]) -> dict[str, float]:
    """Identified models of one measured record against its nonparametric FRF.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        ``identify_measured`` outputs of the record, one per method.
    record : str
        Record name (title).
    coherence_min : float
        ``identify.nonparametric.coherence_min`` (drawn on the coherence panel).
    out : mapping
        ``png`` and ``caption`` paths (the other formats go beside the PNG).

    Returns
    -------
    dict
        ``<method> <pairing>/<version>`` -> match bandwidth [Hz] against the estimate.
    """
    ds0 = datasets[0]
    pairings = list(dict.fromkeys(str(p) for p in ds0.pairing.values))
    fig, axes = new(2, len(pairings), figsize=(5.2 * len(pairings), 6.0), sharex=True,
                    squeeze=False, gridspec_kw={"height_ratios": [2.2, 1]})
    f = ds0.frequency.values
    bws: dict[str, float] = {}
    share: dict[str, float] = {}
    for col, pairing in enumerate(pairings):
        ax, ax_c = axes[0, col], axes[1, col]
        first = ds0.isel(model=int(np.flatnonzero(ds0.pairing.values == pairing)[0]))
        sel = first.isel(output=0, input=0)
        g_ref = sel.frf_reference_real.values + 1j * sel.frf_reference_imag.values
        band = first.assessable.values > 0.5
        share[pairing] = 100 * float(band.mean())
        ax.semilogx(f, db(g_ref), "k", lw=1.6, label="nonparametric estimate")
        ax.fill_between(f, db(sel.frf_reference_lower.values),
                        db(sel.frf_reference_upper.values), where=band, color="C3",
                        alpha=0.35, lw=0, label="95 % bounds (where coherent)")
        ax_c.semilogx(f, sel.coherence.values, "k", lw=1.0)
        ax_c.axhline(coherence_min, color="r", lw=0.8, ls="--",
                     label=f"coherence_min = {coherence_min:g}")
        for ds in datasets:
            method = ds.attrs["method"]
            for k in np.flatnonzero(ds.pairing.values == pairing):
                m = ds.isel(model=int(k))
                status = str(m.status.values)
                if status == "failed":  # no model (its reason is in the table)
                    continue
                version = str(m.version.values)
                bw = float(m.match_bandwidth)
                bws[f"{method} {pairing}/{version}"] = bw
                s = m.isel(output=0, input=0)
                ax.semilogx(f, db(s.frf_identified_real.values
                                   + 1j * s.frf_identified_imag.values),
                            color=_COLORS.get(method), ls=_STYLES.get(version, "-"), lw=1.0,
                            label=f"{method.upper()} {version} (order {int(m.order)}, "
                                  f"{status}): {bw:.0f} Hz")
        ax.set_title(f"{pairing}: {record}")
        ax.set_ylabel(f"|G| [dB re 1 {first.frf_unit.values}]")
        ax.legend(fontsize=6, loc="lower left")
        ax_c.set_ylim(0, 1.05)
        ax_c.set_ylabel("coherence [-]")
        ax_c.set_xlabel("frequency [Hz]")
        ax_c.legend(fontsize=6, loc="lower left")
    save(fig, out["png"])
    write_caption(out["caption"], f"Identification of the measured record {record}",
                  "extension (identification where no truth is known)",
                  "Black: nonparametric FRF of the conditioned data (Welch); red: its 95 % "
                  "bounds where it is coherent, the only frequencies where a model is judged. "
                  "Coloured: the subspace models per method (dashed raw, dotted after TSA), "
                  "ok or poor (status in the legend; failed ones are not drawn). "
                  "Match bandwidth: highest frequency up to which a model stays within the "
                  "tolerance or inside the bounds.",
                  {**{f"coherent share {p}": f"{v:.0f} % of the band" for p, v in share.items()},
                   **{k: f"{v:.1f} Hz" for k, v in bws.items()}})
    return bws
