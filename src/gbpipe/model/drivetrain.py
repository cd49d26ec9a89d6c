"""Assembly of gearbox and back-to-back bench mechanisms from the configuration.

Sign conventions. Every angle is positive in the direction of rotation of its own shaft
in operation; the direction reversal of external meshes is not tracked (a torsional model
only needs magnitudes of ratios). A gear mesh is rigid:

* planetary stage, ring fixed to the housing (angle ``h``), carrier angle ``a``:
  ``sun = (1 + Zr/Zs)·a − (Zr/Zs)·h``, planet (absolute) ``= a + (Zr/Zp)·(h − a)``;
* parallel stage, bearings in the housing: ``pinion = h + (Zw/Zp)·(a − h)``.

With the housing fixed (``mount: fixed``) ``h = 0`` and these are the plain ratios.

Stage inertias in the config are either one number, lumped on the stage's input member
(carrier or wheel) — the form of the paper's starting values — or a mapping of own-axis
member inertias (``{carrier, planet, sun}`` with ``planet`` per planet; ``{wheel, pinion}``).

Damping: ``c = 2ξ√(k·J_eq)``, ``J_eq = Ja·Jb/(Ja + Jb)`` with ``Ja``, ``Jb`` the inertias of
the two bodies the element joins, referred to the element's own speed (a mount joins the
housing to ground: ``J_eq = J_housing``). The gear damping ratio ξ_G has no relative
coordinate to act on while gears are rigid; it is kept in the config and reported as
unused, ready for a flexible-mesh extension.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np

from gbpipe.kinematics import Stage, parse_stages
from gbpipe.model.mechanics import Body, Mechanism, Spring

__all__ = ["gearbox_mechanism", "bench_mechanism", "damping_coefficient"]


def damping_coefficient(k: float, ja: float, jb: float | None, ratio: float) -> float:
    """Viscous damping [N·m·s/rad] of a spring from its damping ratio.

    Parameters
    ----------
    k : float
        Stiffness [N·m/rad].
    ja, jb : float
        Inertias [kg·m²] of the bodies on either side, referred to the element's speed;
        ``jb=None`` for ground.
    ratio : float
        Damping ratio ξ [-].
    """
    jeq = ja if jb is None else ja * jb / (ja + jb)
    return 2.0 * ratio * np.sqrt(k * jeq)


def _stage_bodies(prefix: str, i: int, st: Stage, inertia: Any, group: str) -> list[Body]:
    names = (["carrier", "planet", "sun"] if st.type == "planetary" else ["wheel", "pinion"])
    if isinstance(inertia, Mapping):
        values = {m: float(inertia.get(m, 0.0)) for m in names}
        if st.type == "planetary":
            values["planet"] *= st.planets  # the planets move together in torsion
    else:
        values = {m: 0.0 for m in names}
        values[st.input_member] = float(inertia)
    return [Body(f"{prefix}{m}{i}", values[m], "gear", group) for m in names]


def _stage_constraints(st: Stage) -> dict[str, tuple[Fraction, Fraction]]:
    """Member angle = α·(input angle) + β·(housing angle), as (α, β) per member."""
    if st.type == "planetary":
        zr, zp, zs = st.teeth["ring"], st.teeth["planet"], st.teeth["sun"]
        return {
            "carrier": (Fraction(1), Fraction(0)),
            "planet": (1 - Fraction(zr, zp), Fraction(zr, zp)),
            "sun": (1 + Fraction(zr, zs), -Fraction(zr, zs)),
        }
    r = Fraction(st.teeth["wheel"], st.teeth["pinion"])
    return {"wheel": (Fraction(1), Fraction(0)), "pinion": (r, 1 - r)}


def _stage_numbers(st: Stage) -> tuple[dict[str, tuple[float, float]], float]:
    """:func:`_stage_constraints` and the stage ratio as floats (a shared, read-only dict).

    Cached by tooth counts: a fit assembles the same stages once per model evaluation,
    and the exact fractions were a noticeable share of that.
    """
    return _numbers_of(st.type, tuple(st.teeth.items()), st.planets)


@lru_cache(maxsize=64)
def _numbers_of(kind: str, teeth: tuple[tuple[str, int], ...], planets: int
                ) -> tuple[dict[str, tuple[float, float]], float]:
    st = Stage(kind, dict(teeth), planets)
    return ({m: (float(a), float(b)) for m, (a, b) in _stage_constraints(st).items()},
            float(st.ratio))


def _add_gearbox(mech: Mechanism, gb: Mapping[str, Any], stages: list[Stage], prefix: str,
                 group: str, cols: list[list[tuple[int, float]]]) -> dict[str, str]:
    """Append one gearbox's bodies, springs and constraint columns; return port names.

    ``stages`` is ``parse_stages(gb["stages"])`` (parsed once for both bench gearboxes).
    """
    elastic = gb["housing"]["mount"] == "elastic"
    xi_s = float(gb["damping_ratio"]["shaft"])

    # independent coordinates: housing (if elastic), each stage's input member, flange
    coord_housing = None
    if elastic:
        coord_housing = len(mech.coords)
        mech.coords.append(f"{prefix}housing")
        mech.bodies.append(Body(f"{prefix}housing", float(gb["housing"]["inertia"]),
                                "housing", group))
        cols.append([(coord_housing, 1.0)])
    for i, st in enumerate(stages, start=1):
        c_in = len(mech.coords)
        mech.coords.append(f"{prefix}stage{i}")
        cons, ratio = _stage_numbers(st)
        for body in _stage_bodies(prefix, i, st, gb["inertia"][i - 1], group):
            member = body.name[len(prefix):-len(str(i))]
            alpha, beta = cons[member]
            entries = [(c_in, alpha)]
            if coord_housing is not None and beta != 0:
                entries.append((coord_housing, beta))
            mech.bodies.append(body)
            cols.append(entries)
        mech.meshes.append({
            "name": f"{prefix}mesh{i}", "stage": i, "type": st.type, "group": group,
            "members": [f"{prefix}{m}{i}" for m in cons],
            "ratio": ratio,
        })
    c_fl = len(mech.coords)
    mech.coords.append(f"{prefix}flange")
    mech.bodies.append(Body(f"{prefix}flange", float(gb["inertia"][-1]), "flange", group))
    cols.append([(c_fl, 1.0)])

    # shafts: output member of stage i -> input member of stage i+1 (or the flange)
    for i, st in enumerate(stages, start=1):
        out_body = f"{prefix}{st.output_member}{i}"
        nxt = (f"{prefix}{stages[i].input_member}{i + 1}" if i < len(stages)
               else f"{prefix}flange")
        k = float(gb["stiffness"][i - 1])
        mech.springs.append(Spring(f"{prefix}shaft{i}", {nxt: 1.0, out_body: -1.0}, k,
                                   kind="shaft", damping_ratio=xi_s))
    if elastic:
        h = gb["housing"]
        mech.springs.append(Spring(f"{prefix}mount", {f"{prefix}housing": 1.0},
                                   float(h["stiffness"]), kind="mount",
                                   damping_ratio=float(h["damping_ratio"])))
    return {"lss": f"{prefix}carrier1" if stages[0].type == "planetary"
            else f"{prefix}wheel1", "hss": f"{prefix}flange"}


def _finish(mech: Mechanism, cols: list[list[tuple[int, float]]]) -> Mechanism:
    T = np.zeros((len(mech.bodies), len(mech.coords)))
    for r, entries in enumerate(cols):
        for c, v in entries:
            T[r, c] += v
    mech.T = T
    _set_damping(mech)
    return mech


def _group_inertias(mech: Mechanism) -> np.ndarray:
    """Per body: inertia of the rigid group containing it, referred to its speed [kg·m²].

    The group is every body driven by the same independent coordinate (housing held);
    kinetic energy ½ Σ J_b (∂θ_b/∂q)² ω_q² expressed at the speed of the body. A housing,
    or a body that moves with several coordinates, counts alone (its own inertia).
    """
    t = mech.T.copy()
    t[:, [i for i, c in enumerate(mech.coords) if c.endswith("housing")]] = 0.0
    j = np.array([b.inertia for b in mech.bodies])
    # each group's inertia at its coordinate's speed, once for all the bodies in it (one
    # contiguous row per coordinate: each sum as np.sum of that column alone)
    j_q = np.ascontiguousarray((j[:, None] * t ** 2).T).sum(axis=1)
    rows = np.nonzero((np.count_nonzero(t, axis=1) == 1)
                      & np.array([b.kind != "housing" for b in mech.bodies]))[0]
    c = np.argmax(t[rows] != 0, axis=1)
    out = j.copy()
    out[rows] = j_q[c] / t[rows, c] ** 2
    return out


def _set_damping(mech: Mechanism) -> None:
    idx = mech.body_index
    inertia = _group_inertias(mech)
    for s in mech.springs:
        ends = [idx[b] for b in s.incidence if b in idx]
        jb = inertia[ends[1]] if len(ends) > 1 else None
        s.damping = damping_coefficient(s.stiffness, inertia[ends[0]], jb, s.damping_ratio)


def gearbox_mechanism(cfg: Mapping[str, Any]) -> tuple[Mechanism, dict[str, str]]:
    """The mechanism of one gearbox with free LSS and HSS ends.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (uses ``cfg["gearbox"]``).

    Returns
    -------
    Mechanism, dict
        The mechanism and its port bodies ``{"lss": ..., "hss": ...}``.
    """
    mech = Mechanism()
    cols: list[list[tuple[int, float]]] = []
    stages = parse_stages(cfg["gearbox"]["stages"])
    ports = _add_gearbox(mech, cfg["gearbox"], stages, "", "gb", cols)
    return _finish(mech, cols), ports


def bench_mechanism(cfg: Mapping[str, Any]) -> tuple[Mechanism, dict[str, str]]:
    """The back-to-back bench: driver motor, GB2 (reducer), LSS shaft, GB1, driven motor.

    Returns
    -------
    Mechanism, dict
        The mechanism and named bodies: ``driver_motor``, ``gb2_hss``, ``gb2_lss``,
        ``gb1_lss``, ``gb1_hss``, ``driven_motor``.
    """
    bench = cfg["bench"]
    mech = Mechanism()
    cols: list[list[tuple[int, float]]] = []
    mech.coords.append("driver_motor")
    mech.bodies.append(Body("driver_motor", float(bench["motor_inertia"]["driver"]),
                            "motor", "bench"))
    cols.append([(0, 1.0)])
    stages = parse_stages(cfg["gearbox"]["stages"])
    p2 = _add_gearbox(mech, cfg["gearbox"], stages, "gb2.", "gb2", cols)
    p1 = _add_gearbox(mech, cfg["gearbox"], stages, "gb1.", "gb1", cols)
    c = len(mech.coords)
    mech.coords.append("driven_motor")
    mech.bodies.append(Body("driven_motor", float(bench["motor_inertia"]["driven"]),
                            "motor", "bench"))
    cols.append([(c, 1.0)])
    cp, ls = bench["coupling"], bench["lss_shaft"]
    # twists positive in normal operation: driver drives GB2's HSS, GB2 drives GB1 through
    # the LSS, GB1's HSS drives the (braking) driven motor
    mech.springs += [
        Spring("driver_coupling", {"driver_motor": 1.0, p2["hss"]: -1.0},
               float(cp["stiffness"]), kind="coupling", damping_ratio=float(cp["damping_ratio"])),
        Spring("lss_shaft", {p2["lss"]: 1.0, p1["lss"]: -1.0}, float(ls["stiffness"]),
               kind="lss_shaft", damping_ratio=float(ls["damping_ratio"])),
        Spring("driven_coupling", {p1["hss"]: 1.0, "driven_motor": -1.0},
               float(cp["stiffness"]), kind="coupling", damping_ratio=float(cp["damping_ratio"])),
    ]
    _finish(mech, cols)
    return mech, {"driver_motor": "driver_motor", "gb2_hss": p2["hss"], "gb2_lss": p2["lss"],
                  "gb1_lss": p1["lss"], "gb1_hss": p1["hss"], "driven_motor": "driven_motor"}
