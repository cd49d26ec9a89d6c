"""The paper's Table 2 (shaft and mesh frequencies) and its comparison with the teeth.

Rows only: :func:`gbpipe.io.write_csv` writes them.
"""

from __future__ import annotations

import json

import xarray as xr

__all__ = ["table2", "PAPER_TABLE2", "TABLE1_STAGES"]

#: Teeth of the SGRE 3.X 50 Hz gearbox (paper Table 1).
TABLE1_STAGES = [
    {"type": "planetary", "ring": 96, "planet": 35, "sun": 24, "planets": 4},
    {"type": "planetary", "ring": 114, "planet": 45, "sun": 21, "planets": 3},
    {"type": "parallel", "wheel": 96, "pinion": 29},
]

#: Table 2 as printed in the paper: row -> (frequency [Hz] at 1120 rpm, order of HSS).
PAPER_TABLE2 = {
    "HSS": ("hss", 18.6667, 1.0),
    "HSIS (SUN2)": ("is2", 5.6389, 0.3021),
    "SUN1 (PC2)": ("is1", 0.8772, 0.0470),
    "PC1 (LSS)": ("lss", 0.1754, 0.0094),
    "GMF1": ("mesh1", 16.8414, 0.9022),
    "GMF2": ("mesh2", 5.6389, 5.3569),
    "GMF3": ("mesh3", 541.3333, 29.0),
}


def _stages_json(stages) -> str:
    return json.dumps([dict(sorted(s.items())) for s in stages], sort_keys=True)


def table2(freq: xr.Dataset, stages) -> tuple[list[dict], list[str]]:
    """Rows of Table 2 (every shaft and mesh) and notes on disagreements with the paper.

    Parameters
    ----------
    freq : xarray.Dataset
        Output of :func:`gbpipe.kinematics.frequencies` at one speed.
    stages : list of mapping
        The gearbox stages (to recognise the paper's gearbox).

    Returns
    -------
    rows : list of dict
        ``name, members, frequency_hz, order, order_exact`` and, for the paper's gearbox,
        ``paper_frequency_hz, paper_order``.
    notes : list of str
        One line per paper value that disagrees with the teeth at 4 significant digits.
    """
    paper = _stages_json(stages) == _stages_json(TABLE1_STAGES)
    rows, notes = [], []
    lookup = {v[0]: (k, v[1], v[2]) for k, v in PAPER_TABLE2.items()}
    entries = [("shaft", s) for s in freq.shaft.values[::-1]] + [
        ("mesh", m) for m in freq.mesh.values]
    for dim, name in entries:
        sel = freq.sel({dim: name})
        f = float(sel[f"{dim}_frequency"])
        o = float(sel[f"{dim}_order"])
        exact = f"{int(sel[f'{dim}_order_numerator'])}/{int(sel[f'{dim}_order_denominator'])}"
        row = {"name": str(name), "members": str(sel["shaft_members"].values)
               if dim == "shaft" else f"stage {str(name)[4:]} mesh",
               "frequency_hz": f"{f:.10g}", "order": f"{o:.10g}", "order_exact": exact}
        if paper and name in lookup:
            label, pf, po = lookup[name]
            row.update(paper_label=label, paper_frequency_hz=pf, paper_order=po)
            if f"{f:.4g}" != f"{pf:.4g}" and f"{o:.4g}" == f"{po:.4g}":
                notes.append(
                    f"{label}: the paper prints {pf} Hz, but its own order {po} and the teeth "
                    f"give {po} x {float(freq.hss_rpm) / 60:.4f} Hz = {f:.1f} Hz; "
                    f"gbpipe reports {f:.1f} Hz"
                )
        rows.append(row)
    return rows, notes
