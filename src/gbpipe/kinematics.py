"""Gearbox kinematics from tooth counts: shaft speeds, gear-mesh frequencies and orders.

A gearbox is an ordered list of stages from the low-speed shaft (LSS) to the high-speed
shaft (HSS). Each stage is a mapping:

* ``{type: planetary, ring: Zr, planet: Zp, sun: Zs, planets: n}`` with the ring fixed
  to the housing, carrier in and sun out: ratio ``1 + Zr/Zs``, mesh frequency ``Zr·f_carrier``;
* ``{type: parallel, wheel: Zw, pinion: Zp}``, wheel in and pinion out: ratio ``Zw/Zp``,
  mesh frequency ``Zw·f_wheel``.

Every ratio and order is kept as an exact :class:`fractions.Fraction`, so that virtual
tachometers (e.g. the stage-2 carrier at 0.0470 HSS orders) are never typed in by hand.
Orders are relative to the HSS: order 1 is one event per HSS revolution.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import xarray as xr

__all__ = [
    "Stage",
    "parse_stages",
    "stage_ratio",
    "total_ratio",
    "frequencies",
    "order_of",
    "whole_multiple",
    "excitation_lines",
    "shaft_names",
    "mesh_names",
    "pulsating_orders",
]

_PLANETARY_KEYS = ("ring", "planet", "sun", "planets")
_PARALLEL_KEYS = ("wheel", "pinion")


@dataclass(frozen=True)
class Stage:
    """One gear stage, validated.

    Attributes
    ----------
    type : {"planetary", "parallel"}
    teeth : dict
        Tooth counts by member name (``ring``, ``planet``, ``sun`` or ``wheel``, ``pinion``).
    planets : int
        Number of planets (0 for a parallel stage).
    """

    type: str
    teeth: Mapping[str, int]
    planets: int = 0

    @property
    def ratio(self) -> Fraction:
        """Speed ratio output/input as an exact fraction (> 1 for a speed increaser)."""
        t = self.teeth
        if self.type == "planetary":
            return Fraction(t["ring"] + t["sun"], t["sun"])
        return Fraction(t["wheel"], t["pinion"])

    @property
    def mesh_teeth(self) -> int:
        """Teeth of the member whose rotation relative to the mesh defines the mesh frequency."""
        return self.teeth["ring"] if self.type == "planetary" else self.teeth["wheel"]

    @property
    def input_member(self) -> str:
        return "carrier" if self.type == "planetary" else "wheel"

    @property
    def output_member(self) -> str:
        return "sun" if self.type == "planetary" else "pinion"


def _teeth(stage: Mapping[str, Any], key: str, where: str) -> int:
    if key not in stage:
        raise ValueError(f"{where}.{key}: missing tooth count; add '{key}: <integer>'")
    value = stage[key]
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise ValueError(
                f"{where}.{key}: tooth counts are whole numbers, got {value!r}; "
                "give an integer"
            )
    if value < 1:
        raise ValueError(f"{where}.{key}: tooth count must be ≥ 1, got {value}")
    return int(value)


def parse_stages(stages: Sequence[Mapping[str, Any]] | Sequence[Stage]) -> list[Stage]:
    """Validate stage mappings and return :class:`Stage` objects.

    Parameters
    ----------
    stages : sequence of mapping
        Stages from LSS to HSS, as in the ``gearbox.stages`` config list.

    Returns
    -------
    list of Stage

    Raises
    ------
    ValueError
        Unknown stage type, missing, non-integer or non-positive teeth, or a ring with no
        more teeth than its sun. The assembly rule ``Zr = Zs + 2·Zp`` is not enforced:
        profile shift lets real gearboxes deviate from it (Table 1: 96 ≠ 24 + 70).
    """
    if isinstance(stages, Mapping) or len(stages) == 0:
        raise ValueError("gearbox.stages: give a non-empty list of stages from LSS to HSS")
    out: list[Stage] = []
    for i, st in enumerate(stages):
        if isinstance(st, Stage):
            out.append(st)
            continue
        where = f"gearbox.stages[{i}]"
        if not isinstance(st, Mapping):
            raise ValueError(f"{where}: each stage is a mapping with a 'type' key")
        kind = st.get("type")
        if kind == "planetary":
            teeth = {k: _teeth(st, k, where) for k in _PLANETARY_KEYS[:3]}
            planets = _teeth(st, "planets", where)
            if teeth["ring"] <= teeth["sun"]:
                raise ValueError(
                    f"{where}.ring: ring teeth ({teeth['ring']}) must exceed sun teeth "
                    f"({teeth['sun']}) in a planetary stage"
                )
            out.append(Stage("planetary", teeth, planets))
        elif kind == "parallel":
            teeth = {k: _teeth(st, k, where) for k in _PARALLEL_KEYS}
            out.append(Stage("parallel", teeth, 0))
        else:
            raise ValueError(
                f"{where}.type: unknown stage type {kind!r}; use 'planetary' or 'parallel'"
            )
    return out


def stage_ratio(stage: Mapping[str, Any] | Stage) -> Fraction:
    """Exact speed ratio (output/input) of one stage."""
    return parse_stages([stage])[0].ratio


def total_ratio(stages: Sequence[Mapping[str, Any]] | Sequence[Stage]) -> Fraction:
    """Exact HSS/LSS speed ratio of the gearbox."""
    r = Fraction(1)
    for st in parse_stages(stages):
        r *= st.ratio
    return r


def shaft_names(n_stages: int) -> list[str]:
    """Names of the shafts: ``lss``, ``is1`` … ``is{n-1}`` (intermediate), ``hss``."""
    return ["lss"] + [f"is{k}" for k in range(1, n_stages)] + ["hss"]


def mesh_names(n_stages: int) -> list[str]:
    """Names of the gear meshes: ``mesh1`` … ``mesh{n}`` from the LSS side."""
    return [f"mesh{k}" for k in range(1, n_stages + 1)]


def _shaft_orders(stages: list[Stage]) -> list[Fraction]:
    # Order of shaft k (k = 0 LSS … n HSS) relative to the HSS: product of downstream ratios.
    orders = [Fraction(1)]
    for st in reversed(stages):
        orders.insert(0, orders[0] / st.ratio)
    return orders


def _shaft_members(stages: list[Stage]) -> list[str]:
    labels = []
    for k in range(len(stages) + 1):
        parts = []
        if k > 0:
            parts.append(f"{stages[k - 1].output_member}{k}")
        if k < len(stages):
            parts.append(f"{stages[k].input_member}{k + 1}")
        labels.append("/".join(parts))
    return labels


def _orders_table(stages: list[Stage]) -> dict[str, Fraction]:
    shaft_ord = _shaft_orders(stages)
    table: dict[str, Fraction] = {}
    for name, o in zip(shaft_names(len(stages)), shaft_ord, strict=True):
        table[name] = o
    for k, st in enumerate(stages, start=1):
        f_in = shaft_ord[k - 1]
        table[f"mesh{k}"] = st.mesh_teeth * f_in
        table[f"{st.input_member}{k}"] = f_in
        table[f"{st.output_member}{k}"] = shaft_ord[k]
        if st.type == "planetary":
            # planet spin relative to its carrier: Zr/Zp revolutions per carrier revolution
            table[f"planet{k}"] = Fraction(st.teeth["ring"], st.teeth["planet"]) * f_in
            # a planet passes a fixed point of the ring n times per carrier revolution
            table[f"planet_pass{k}"] = st.planets * f_in
    return table


def order_of(stages: Sequence[Mapping[str, Any]] | Sequence[Stage], name: str) -> Fraction:
    """Exact order (events per HSS revolution) of a named shaft, member or mesh.

    Parameters
    ----------
    stages : sequence
        Gearbox stages from LSS to HSS.
    name : str
        ``lss``, ``is<k>``, ``hss``, ``mesh<k>``, a member ``carrier<k>``, ``sun<k>``,
        ``wheel<k>``, ``pinion<k>``, ``planet<k>`` (spin relative to the carrier) or
        ``planet_pass<k>`` (planet-pass rate), with stages numbered from 1 at the LSS.

    Returns
    -------
    fractions.Fraction

    Examples
    --------
    >>> st = [dict(type="planetary", ring=96, planet=35, sun=24, planets=4),
    ...       dict(type="planetary", ring=114, planet=45, sun=21, planets=3),
    ...       dict(type="parallel", wheel=96, pinion=29)]
    >>> float(order_of(st, "mesh2"))  # doctest: +ELLIPSIS
    5.3569...
    """
    table = _orders_table(parse_stages(stages))
    if name not in table:
        raise ValueError(f"unknown shaft, member or mesh {name!r}; known: {', '.join(table)}")
    return table[name]


def frequencies(
    stages: Sequence[Mapping[str, Any]] | Sequence[Stage], hss_rpm: float | Sequence[float]
):
    """Shaft rotation and gear-mesh frequencies and orders of a gearbox.

    Parameters
    ----------
    stages : sequence of mapping
        Stages from LSS to HSS (see module docstring).
    hss_rpm : float or sequence of float
        HSS speed [rev/min]; a sequence adds an ``rpm`` dimension.

    Returns
    -------
    xarray.Dataset
        ``shaft_frequency`` [Hz] and ``shaft_order`` [-] on dimension ``shaft``
        (``lss`` … ``hss``), ``mesh_frequency`` [Hz] and ``mesh_order`` [-] on dimension
        ``mesh``, the exact orders as ``*_order_numerator``/``*_order_denominator``, and
        ``stage_ratio``, ``total_ratio``. Orders are relative to the HSS.
    """
    st = parse_stages(stages)
    rpm = np.asarray(hss_rpm, dtype=float)
    if not np.all(np.isfinite(rpm)) or np.any(rpm < 0):
        raise ValueError(f"hss_rpm: give finite, non-negative speeds in rev/min, got {hss_rpm!r}")
    f_hss = rpm / 60.0
    shaft_ord = _shaft_orders(st)
    table = _orders_table(st)
    mesh_ord = [table[m] for m in mesh_names(len(st))]

    def family(dim: str, orders: list[Fraction], what: str) -> dict[str, Any]:
        # frequency, float order and exact order of one family (shafts or meshes)
        o = np.array([float(x) for x in orders])
        data = np.multiply.outer(f_hss, o) if rpm.ndim else f_hss * o
        return {
            f"{dim}_frequency": (("rpm", dim) if rpm.ndim else (dim,), data,
                                 {"units": "Hz", "long_name": f"{what} frequency"}),
            f"{dim}_order": (dim, o, {"units": "1",
                                      "long_name": f"{what} order relative to HSS"}),
            f"{dim}_order_numerator": (dim, [x.numerator for x in orders], {
                "units": "1", "long_name": f"exact {dim} order, numerator"}),
            f"{dim}_order_denominator": (dim, [x.denominator for x in orders], {
                "units": "1", "long_name": f"exact {dim} order, denominator"}),
        }

    n = len(st)
    ds = xr.Dataset(
        {
            **family("shaft", shaft_ord, "shaft rotation"),
            **family("mesh", mesh_ord, "gear mesh"),
            "stage_ratio": ("stage", [float(s.ratio) for s in st],
                            {"units": "1", "long_name": "stage speed ratio output/input"}),
            "mesh_teeth": ("mesh", [s.mesh_teeth for s in st],
                           {"units": "1",
                            "long_name": "teeth of the member defining the mesh frequency"}),
            "total_ratio": ((), float(total_ratio(st)),
                            {"units": "1", "long_name": "gearbox speed ratio HSS/LSS"}),
        },
        coords={
            "shaft": ("shaft", shaft_names(n), {"units": "1", "long_name": "shaft"}),
            "shaft_members": ("shaft", _shaft_members(st),
                              {"units": "1", "long_name": "gear members on the shaft"}),
            "mesh": ("mesh", mesh_names(n), {"units": "1", "long_name": "gear mesh"}),
            "stage": ("stage", np.arange(1, n + 1),
                      {"units": "1", "long_name": "gear stage number from the LSS side"}),
            "stage_type": ("stage", [s.type for s in st],
                           {"units": "1", "long_name": "stage type"}),
        },
    )
    if rpm.ndim:
        ds = ds.assign_coords(rpm=("rpm", rpm, {"units": "rev/min", "long_name": "HSS speed"}))
    else:
        ds["hss_rpm"] = ((), float(rpm), {"units": "rev/min", "long_name": "HSS speed"})
    return ds


def whole_multiple(order: Fraction | int, cycles: Sequence[Fraction]) -> bool:
    """Whether an HSS ``order`` is a whole multiple of one of the ``cycles`` (HSS orders).

    Exact: ``order / c`` an integer, with Fractions from the teeth (no tolerance). A line
    of that order repeats identically every cycle ``c``, so a synchronous removal of ``c``
    (TSA, or any method of :mod:`gbpipe.harmonics`) takes it off.
    """
    return any((Fraction(order) / c).denominator == 1 for c in cycles)


def excitation_lines(excitation: Mapping[str, Any], stages: Sequence[Mapping[str, Any]]
                     ) -> dict[str, list[tuple[Fraction, float]]]:
    """HSS orders and amplitudes of the angle-locked gear excitation's lines.

    The one place the ``excitation`` section becomes lines (harmonic families, the design
    step's spectra).

    Parameters
    ----------
    excitation : mapping
        ``cfg["excitation"]``: ``shaft_orders`` (``order``, ``amplitude`` [rad]) and
        ``mesh`` (``stage``, ``amplitude`` [rad], ``harmonics`` weights).
    stages : sequence of mapping
        ``gearbox.stages`` (exact mesh orders).

    Returns
    -------
    dict
        ``"shaft"`` -> ``(order, amplitude)`` per shaft order; ``"mesh<k>"`` ->
        ``(h x mesh order, amplitude x weight)`` per harmonic ``h`` of stage k's mesh; in
        config order, orders as exact Fractions.
    """
    lines = {"shaft": [(Fraction(s["order"]).limit_denominator(1000), float(s["amplitude"]))
                       for s in excitation["shaft_orders"]]}
    for m in excitation["mesh"]:
        o = order_of(stages, f"mesh{m['stage']}")
        lines[f"mesh{m['stage']}"] = [(h * o, float(m["amplitude"]) * float(w))
                                      for h, w in enumerate(m["harmonics"], start=1)]
    return lines


def pulsating_orders(ripple: Mapping[str, Any]) -> list[tuple[int, float]]:
    """Shaft orders and amplitudes of a converter-fed motor's pulsating torque.

    Harmonic ``h`` of the electrical frequency is locked to the motor shaft angle at order
    ``h x pole_pairs``: the electrical angle is ``pole_pairs`` times the mechanical one.
    The one place that rule lives (simulation, harmonic families, noise spectra).

    Parameters
    ----------
    ripple : mapping
        One motor's ``noise.motor_ripple`` entry: ``pole_pairs`` (default 1) and
        ``pulsating``, a list of ``{harmonic, amplitude}`` [1, N m].

    Returns
    -------
    list of (int, float)
        ``(order, amplitude)`` per pulsating line, in the configured order.
    """
    pairs = int(ripple.get("pole_pairs", 1))
    return [(int(line["harmonic"]) * pairs, float(line["amplitude"]))
            for line in ripple.get("pulsating", ())]
