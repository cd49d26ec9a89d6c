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

__all__ = ["stabilization_orders", "row_order", "order_windows"]


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

        A pairing whose order is not a positive integer (its diagram found nothing) is
        left out of ``orders``; its provenance says why, and :func:`row_order` gives it
        no order, so its rows fail with that reason while the other pairings go on.

    Raises
    ------
    gbpipe.errors.DataError
        ``model_order`` missing, or a pairing absent.
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
        where = f"{source} model_order[method={row}, pairing={p}]"
        if not (np.isfinite(val) and val >= 1 and val == round(val)):
            # this pairing's rows fail with the reason; the other pairings go on
            why = (str(modes["status"].sel({"method": row, "pairing": p}).values)
                   if "status" in modes else "")
            prov[p] = (f"no model order: {where} is {val:g} (the stabilization diagram found "
                       f"no stable cluster{': ' + why if why else ''}); set identify.order "
                       "to an integer, or widen identify.stabilization.orders")
            continue
        orders[p] = int(val)
        prov[p] = f"stabilization: {where}"
    return orders, prov


def row_order(s: Mapping[str, Any], pairing: str,
              orders: Mapping[str, int] | None,
              provenance: Mapping[str, str] | None = None) -> tuple[int | str | None, str]:
    """The order one pairing is fitted with (an integer or ``"auto"``) and its source.

    ``orders`` (from :func:`stabilization_orders`) wins over ``identify.order`` when it
    names the pairing. ``stabilization`` without an order for the pairing gives None and
    the reason (no diagram was given, or it found nothing): the pairing's rows fail with
    it. No constant of the configured bench stands in for a diagram.
    """
    if orders is not None and pairing in orders:
        src = (provenance or {}).get(pairing, "orders given to identify_methods")
        return int(orders[pairing]), src
    order = s["order"]
    if order == "stabilization":
        return None, (provenance or {}).get(
            pairing, "no model order: identify.order is stabilization, but no stabilization "
            "diagram's orders were given (gbpipe.identify.orders.stabilization_orders)")
    if order == "auto":
        return "auto", f"auto from the singular values (at most {s['max_order']})"
    return int(order), f"identify.order = {order}"


def order_windows(s: Mapping[str, Any], order: int | str, n_outputs: int) -> dict[str, int]:
    """``past`` and ``future`` [samples] that hold a model of ``order``.

    ``identify.past`` and ``identify.future``, lengthened where ``future`` block rows of
    ``n_outputs`` outputs give fewer than ``order + 1`` rows (``past`` at least one more):
    an order read off a stabilization diagram may exceed what the configured windows
    allow. The diagram and the fit of that order use the same windows. ``"auto"`` keeps
    the configured ones.
    """
    if not isinstance(order, int):  # "auto", or no order (the row fails)
        return {"past": int(s["past"]), "future": int(s["future"])}
    future = max(int(s["future"]), -(-(int(order) + 1) // int(n_outputs)))
    return {"past": max(int(s["past"]), future + 1), "future": future}
