"""What every physical fit writes, whatever its data: parameters, goodness, modes.

:func:`result_variables` gives the variables and coordinates of a
:class:`gbpipe.fit.estimate.FitResult` common to the FRF fit (:func:`gbpipe.fit.fit_dataset`)
and the modal-table fit (:func:`modal_fit_dataset`): estimates with their 95 % intervals
and status, correlations, costs, the chi-square test and where its misfit sits (per
pairing or mode, per frequency band), and for a modal table the mode-by-mode comparison
of data, prior and fitted model. See docs/fit.md and docs/architecture.md ("Data
contract").
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.fit.estimate import FitResult
from gbpipe.fit.keypath import parse_path

__all__ = ["result_variables", "modal_fit_dataset", "parameter_unit", "cf_var"]

# "damping_ratio" before "damping": the first key contained in the path wins
_UNITS = {"inertia": "kg m2", "stiffness": "N m rad-1", "damping_ratio": "1",
          "damping": "N m s rad-1",
          "speed_controller.kp": "N m s rad-1", "speed_controller.ki": "N m rad-1",
          "torque_controller.kp": "1", "torque_controller.ki": "s-1"}
_CHAIN_GAIN = re.compile(r"^(drivetrain\.motors\[\d+\]\.controller)\.(kp|ki)$")


def parameter_unit(path: str, cfg: Mapping[str, Any] | None = None) -> str:
    """UDUNITS unit of a free parameter's key path (e.g. ``N m rad-1`` for a stiffness).

    A drivetrain motor's controller gain (``drivetrain.motors[k].controller.kp``) has the
    unit of its controller's type (speed or torque), read from `cfg`.

    Raises
    ------
    ValueError
        A drivetrain controller gain without `cfg`.
    """
    gain = _CHAIN_GAIN.match(path)
    if gain:
        if cfg is None:
            raise ValueError(f"{path}: the unit depends on the controller type; pass cfg")
        node: Any = cfg
        for key in parse_path(gain.group(1)):
            node = node[key]
        path = f"{node.get('type', 'none')}_controller.{gain.group(2)}"
    for key, unit in _UNITS.items():
        if "." in key and key in path:
            return unit
    for key, unit in _UNITS.items():
        if key in path:
            return unit
    return "1"


def cf_var(dims: tuple[str, ...], values: Any, unit: str, name: str) -> tuple:
    """``(dims, values, {units, long_name})`` of one dataset variable."""
    return dims, values, {"units": unit, "long_name": name}


def result_variables(result: FitResult, cfg: Mapping[str, Any]
                     ) -> tuple[dict[str, tuple], dict[str, tuple], dict[str, Any]]:
    """Data variables, coordinates and attributes of a fit result.

    Parameters
    ----------
    result : FitResult
    cfg : mapping
        The configuration the fit started from (the units of its free parameters).

    Returns
    -------
    variables, coords, attrs : dict
        For :class:`xarray.Dataset`. The misfit shares are on ``misfit_group`` (the
        pairings or modes, in fit order) and ``band`` (frequency bands, edges in
        ``band_lower``/``band_upper`` [Hz]).
    """
    par, g = result.free, result.goodness
    pdim, mixed = ("parameter",), "mixed (see parameter_units)"
    v = {
        "prior": cf_var(pdim, result.prior, mixed, "value the fit started from"),
        "estimate": cf_var(pdim, result.value, mixed,
                         "fitted value (the prior for an unidentifiable parameter)"),
        "interval_lower": cf_var(pdim, result.interval[:, 0], mixed,
                               "lower end of the 95 % interval"),
        "interval_upper": cf_var(pdim, result.interval[:, 1], mixed,
                               "upper end of the 95 % interval"),
        "status": cf_var(pdim, np.array(result.status), "1",
                       "identified, poor (determined, fit failed its chi-square test), "
                       "untested (determined, no sigma to test the fit against), "
                       "conditional (partner held) or unidentifiable"),
        "correlation": cf_var(("parameter", "parameter_col"), result.correlation, "1",
                            "correlation of the determined log-parameters"),
        "cost_prior": cf_var((), result.cost_prior, "1",
                           "half sum of squared weighted residuals at the prior"),
        "cost": cf_var((), result.cost, "1", "half sum of squared weighted residuals"),
        "noise_scale": cf_var((), result.noise_scale, "1",
                            "standard deviation of a weighted residual (interval scale)"),
        "start_cost": cf_var(("start",), result.start_costs, "1",
                           "final cost of each local run (starts, then the evolution's)"),
        "chi2": cf_var((), g.chi2, "1", "sum of squared weighted residuals at the fit"),
        "chi2_dof": cf_var((), g.dof, "1", "effective degrees of freedom N/c - n"),
        "chi2_p": cf_var((), g.p_value, "1", "p-value of the chi-square test"),
        "correlation_factor": cf_var((), g.correlation_factor, "1",
                                   "correlation factor c of the residuals along frequency"),
        "misfit_share": cf_var(("misfit_group",), g.group_share, "1",
                             "share of chi2 of each pairing (or mode)"),
        "misfit_count_share": cf_var(("misfit_group",), g.group_count_share, "1",
                                   "share of the residuals of each pairing (or mode)"),
        "band_misfit_share": cf_var(("band",), g.band_share, "1",
                                  "share of chi2 of each frequency band"),
        "band_count_share": cf_var(("band",), g.band_count_share, "1",
                                 "share of the residuals of each frequency band"),
    }
    c = {
        "parameter": cf_var(pdim, np.array(par), "1", "free parameter (config key path)"),
        "parameter_col": cf_var(("parameter_col",), np.array(par), "1",
                              "free parameter (config key path)"),
        "parameter_units": cf_var(pdim, np.array([parameter_unit(p, cfg) for p in par]), "1",
                                "unit of each parameter"),
        "start": cf_var(("start",), np.arange(result.start_costs.size), "1", "local run"),
        "misfit_group": cf_var(("misfit_group",), np.array(g.groups), "1",
                             "pairing (or mode) of the misfit shares"),
        "band_lower": cf_var(("band",), g.band_edges[:-1], "Hz", "lower edge of the band"),
        "band_upper": cf_var(("band",), g.band_edges[1:], "Hz", "upper edge of the band"),
    }
    m = result.modes
    if m is not None:
        mdim = ("mode",)
        for key, unit, name in (
                ("frequency_data", "Hz", "identified natural frequency (the data)"),
                ("frequency_sd", "Hz", "standard deviation of the identified frequency"),
                ("frequency_prior", "Hz", "matched model frequency at the prior"),
                ("frequency_fitted", "Hz", "matched model frequency at the fit"),
                ("damping_data", "1", "identified damping ratio (the data)"),
                ("damping_sd", "1", "standard deviation of the identified damping ratio"),
                ("damping_prior", "1", "matched model damping ratio at the prior"),
                ("damping_fitted", "1", "matched model damping ratio at the fit")):
            v[f"mode_{key}"] = cf_var(mdim, getattr(m, key), unit, name)
        c["mode"] = cf_var(mdim, np.arange(1, m.frequency_data.size + 1), "1", "mode number")
    attrs = {"fit_status": g.status, "fit_reason": g.reason, "chi2_alpha": g.alpha,
             "search": result.search, "n_free": len(par),
             "interval_method": result.interval_method,
             "cannot_separate": " | ".join(result.combinations) or "(nothing)",
             "n_evaluations": result.n_evaluations}
    return v, c, attrs


def modal_fit_dataset(result: FitResult, system: str, cfg: Mapping[str, Any]) -> xr.Dataset:
    """Everything a fit to a modal table produced, as a CF dataset.

    Parameters
    ----------
    result : FitResult
        A fit to :class:`gbpipe.fit.modes.ModalData` (with ``modes``).
    system : str
        Whose modes were fitted: ``plant`` or a pairing's name.
    cfg : mapping
        The configuration the fit started from.
    """
    v, c, attrs = result_variables(result, cfg)
    return xr.Dataset(v, coords=c, attrs={**attrs, "data": "modes", "system": system})
