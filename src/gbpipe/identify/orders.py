"""The model order of each pairing, and where it came from.

``identify.order`` is an integer, ``auto`` (from the singular values) or, for measured
records, ``stabilization``: the order per pairing read from the record's stabilization
diagram (``results/modes/measured/{record}.nc``, variable ``model_order`` with dims
``method`` and ``pairing``, written by the ``modes_measured`` rule). Every identified
model then records the order it used and its source (``order_source``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import DataError

__all__ = ["stabilization_orders", "row_order"]


def stabilization_orders(modes: xr.Dataset, method: str, pairings: Sequence[str],
                         source: str) -> tuple[dict[str, int], dict[str, str]]:
    """Orders per pairing from a stabilization result, and their provenance.

    Parameters
    ----------
    modes : xarray.Dataset
        With ``model_order`` (dims ``method``, ``pairing``; string labels) [-].
    method : str
        The identification method; its own row of ``model_order`` when the diagram has
        one, else the first row (named in the provenance).
    pairings : sequence of str
        The pairings identified (``identify.pairings`` names).
    source : str
        What ``modes`` is (a path), for the provenance.

    Returns
    -------
    orders : dict of str -> int
    provenance : dict of str -> str
        Per pairing, e.g. ``"stabilization: run12.nc model_order[method=pbsid,
        pairing=Tdrv_to_Mdrv]"``.

    Raises
    ------
    gbpipe.errors.DataError
        ``model_order`` missing, a pairing absent, or its order not a positive integer.
    """
    if "model_order" not in modes:
        raise DataError(source, "has no variable model_order (method, pairing): rerun rule "
                        "modes_measured, or set identify.order to an integer or auto")
    mo = modes["model_order"]
    methods = [str(m) for m in mo["method"].values]
    row = method if method in methods else methods[0]
    have = [str(p) for p in mo["pairing"].values]
    orders, prov = {}, {}
    for p in pairings:
        if p not in have:
            raise DataError(source, f"model_order has no pairing {p!r} (it has {have}): rerun "
                            "rule modes_measured for the current identify.pairings")
        val = float(mo.sel({"method": row, "pairing": p}))  # "method" is also a sel() kwarg
        if not (np.isfinite(val) and val >= 1 and val == round(val)):
            raise DataError(source, f"model_order[method={row}, pairing={p}] is {val}, not a "
                            "positive integer: the stabilization diagram found no stable "
                            "order; set identify.order to an integer or auto")
        orders[p] = int(val)
        prov[p] = f"stabilization: {source} model_order[method={row}, pairing={p}]"
    return orders, prov


def row_order(s: Mapping[str, Any], pairing: str,
              orders: Mapping[str, int] | None,
              provenance: Mapping[str, str] | None = None) -> tuple[int | str, str]:
    """The order one pairing is fitted with (an integer or ``"auto"``) and its source.

    ``orders`` (from :func:`stabilization_orders`) wins over ``identify.order`` when it
    names the pairing; ``stabilization`` without them falls back to ``identify.max_order``
    and says so.
    """
    if orders is not None and pairing in orders:
        src = (provenance or {}).get(pairing, "orders given to identify_methods")
        return int(orders[pairing]), src
    order = s["order"]
    if order == "stabilization":
        # no diagram: the bound on the bench's states in the band, not "auto", whose
        # singular values pick orders of 1-4 on bench-like records (docs/identify.md)
        return int(s["max_order"]), (f"identify.max_order = {s['max_order']} (identify.order: "
                                     "stabilization, but no stabilization diagram was given)")
    if order == "auto":
        return "auto", f"auto from the singular values (at most {s['max_order']})"
    return int(order), f"identify.order = {order}"
