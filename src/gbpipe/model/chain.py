"""Any torsional chain from its description: the one builder of the mechanics core.

The description is the ``drivetrain:`` config section (docs/drivetrain.md, the contract an
importer produces and a fit frees by key path)::

    name: text                                   (optional)
    disks: {node: {inertia: J [kg·m²], kind: label?}}          order = coordinate order
    shafts: [{name, between: [a, b], stiffness [N·m/rad],
              damping_ratio [-] | damping [N·m·s/rad], kind: label?}]   twist θ_a − θ_b
    mounts: [{name, node, stiffness, damping_ratio | damping}]           twist θ_node
            (stiffness 0 with damping > 0: a damper to ground)
    gears: [{name, parent, child, teeth: [z_parent, z_child] | ratio, housing: node?,
             stiffness?, damping?}]
            θ_child = θ_h + r·(θ_parent − θ_h),  r = z_parent/z_child (child / parent speed);
            with a stiffness [N·m/rad] an elastic mesh: a spring on the twist
            (θ_parent − θ_h) − (θ_child − θ_h)/r, referred to the parent (openTorsion's
            ElasticGear), the child then a coordinate of its own
    planetary: [{name, carrier, planet, sun, ring: node | null,
                 teeth: {ring, planet, sun}, planets}]    planet disk inertia per planet
    motors: [{name, node, sign: ±1, torque_limit [N·m]?,
              controller: {type: speed | torque | none, sensor, kp, ki,
                           setpoint_weight [-], feedforward [-]}}]
    sensors: [{name, speed: node} | {name, angle: node} | {name, torque: spring, sign}]
    excitation: [{name, shaft: spring}]         angle error [rad] in a shaft or mount

:func:`build_chain` checks it (:mod:`gbpipe.model.chain_checks`, a ``ConfigError`` on the
key path of the bad element) and returns a :class:`Chain`: the
:class:`~gbpipe.model.mechanics.Mechanism` (rigid meshes as constraints θ_full = T q, the
independent coordinates being the disks no mesh constrains), its motors, sensors and
excitation inputs. Damping from a ratio: ``c = 2ξ√(k·J_eq)`` with the rigid groups'
inertias referred to the element's speed, frames (ring and housing nodes) held.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np

from gbpipe.model.chain_checks import check_description, check_inertia
from gbpipe.model.mechanics import Body, Mechanism, Spring

__all__ = ["Controller", "Motor", "Chain", "build_chain", "constraints", "mesh_incidence",
           "damping_coefficient"]


@dataclass(frozen=True)
class Controller:
    """A motor's control law (docs/drivetrain.md, "Controller laws").

    Attributes
    ----------
    type : str
        ``speed`` (PI with set-point weight on a speed sensor), ``torque`` (PI plus
        feed-forward on a torque sensor) or ``none`` (the motor torque is an input).
    sensor : str
        The fed-back sensor (``""`` for ``none``).
    kp : float
        Proportional gain [N·m·s/rad] (speed) or [N·m/N·m] (torque).
    ki : float
        Integral gain [N·m/rad] (speed) or [1/s] (torque).
    setpoint_weight : float
        Weight of the speed reference in the P term [-].
    feedforward : float
        Share of the torque reference applied directly [-] (torque controllers: default 1
        in the description; 0 for the others, which have no torque reference).
    """

    type: str = "none"
    sensor: str = ""
    kp: float = 0.0
    ki: float = 0.0
    setpoint_weight: float = 1.0
    feedforward: float = 0.0


@dataclass(frozen=True)
class Motor:
    """A motor: input ``motor_torque_<name>`` [N·m] acting as ``sign·T`` on ``node``.

    Attributes
    ----------
    name, node : str
    sign : float
        +1 or −1 (−1: a braking torque).
    torque_limit : float or None
        Peak torque [N·m]; None when not given.
    controller : Controller
    index : int
        Position in ``drivetrain.motors`` (for key paths).
    """

    name: str
    node: str
    sign: float
    torque_limit: float | None
    controller: Controller
    index: int = 0

    @property
    def input(self) -> str:
        """The plant input (identification input) of this motor's torque [N·m]."""
        return f"motor_torque_{self.name}"


@dataclass
class Chain:
    """A built drivetrain: mechanism, motors, sensors, excitation.

    Attributes
    ----------
    mechanism : Mechanism
    motors : list of Motor
    speed_sensors, angle_sensors : dict
        Sensor name → node (speed [rad/s], angle [rad]).
    torque_sensors : dict
        Sensor name → (spring, sign) (torque [N·m]).
    excitation : dict
        Input name → spring (angle error [rad]).
    frames : list of str
        Ring/housing nodes (held when referring inertias for damping).
    """

    mechanism: Mechanism
    motors: list[Motor] = field(default_factory=list)
    speed_sensors: dict[str, str] = field(default_factory=dict)
    torque_sensors: dict[str, tuple[str, float]] = field(default_factory=dict)
    angle_sensors: dict[str, str] = field(default_factory=dict)
    excitation: dict[str, str] = field(default_factory=dict)
    frames: list[str] = field(default_factory=list)


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


@lru_cache(maxsize=256)
def _gear_numbers(z_parent: int, z_child: int) -> tuple[float, float]:
    """``(r, 1 − r)`` of a gear mesh, exact from the tooth counts, then as floats.

    Cached: a fit assembles the same meshes once per model evaluation, and the exact
    fractions were a noticeable share of that.
    """
    r = Fraction(z_parent, z_child)
    return float(r), float(1 - r)


@lru_cache(maxsize=256)
def _planetary_numbers(ring: int, planet: int, sun: int) -> tuple[float, ...]:
    """Planet ``(1 − Zr/Zp, Zr/Zp)`` and sun ``(1 + Zr/Zs, −Zr/Zs)`` coefficients."""
    rp, rs = Fraction(ring, planet), Fraction(ring, sun)
    return float(1 - rp), float(rp), float(1 + rs), float(-rs)


def _ratio(entry: Mapping[str, Any]) -> tuple[float, float]:
    if "teeth" in entry:
        return _gear_numbers(int(entry["teeth"][0]), int(entry["teeth"][1]))
    r = float(entry["ratio"])
    return r, 1.0 - r


def constraints(desc: Mapping[str, Any]) -> dict[str, list[tuple[str | None, float]]]:
    """Each constrained node → its angle as ``[(node, coefficient), ...]``.

    ``None`` as a node is ground (a fixed ring or housing). Gears:
    ``child = r·parent + (1 − r)·housing``; planetary: ``planet = (1 − Zr/Zp)·carrier +
    (Zr/Zp)·ring``, ``sun = (1 + Zr/Zs)·carrier − (Zr/Zs)·ring``.
    """
    out: dict[str, list[tuple[str | None, float]]] = {}
    for g in desc.get("gears", []):
        if "stiffness" in g:
            continue      # an elastic mesh is a spring (mesh_incidence), not a constraint
        r, rest = _ratio(g)
        out[g["child"]] = [(g["parent"], r), (g.get("housing"), rest)]
    for p in desc.get("planetary", []):
        t = p["teeth"]
        pc, pr, sc, sr = _planetary_numbers(int(t["ring"]), int(t["planet"]), int(t["sun"]))
        out[p["planet"]] = [(p["carrier"], pc), (p["ring"], pr)]
        out[p["sun"]] = [(p["carrier"], sc), (p["ring"], sr)]
    return out


def mesh_incidence(entry: Mapping[str, Any]) -> dict[str, float]:
    """The twist of an elastic gear mesh over its nodes: body → coefficient.

    ``(θ_parent − θ_h) − (θ_child − θ_h)/r`` [rad], the mesh's relative angle referred to
    the parent (0 when the mesh turns as a rigid one: ``θ_child = θ_h + r·(θ_parent −
    θ_h)``); its stiffness times it is the torque the mesh transmits at the parent
    [N·m] (``1/r`` of it at the child, which it drives). This is
    openTorsion's ``ElasticGear`` (stiffness ``k·g gᵀ``, ``g = [1, R_child/R_parent]`` in
    its reversing frame).
    """
    r = _ratio(entry)[0]
    out = {entry["parent"]: 1.0, entry["child"]: -1.0 / r}
    if entry.get("housing") is not None:
        out[entry["housing"]] = 1.0 / r - 1.0
    return out


def _rows(nodes: list[str], coords: list[str], cons: Mapping[str, list]
          ) -> dict[str, dict[int, float]]:
    """Each node's angle as {coordinate index: coefficient}, constraints resolved."""
    col = {c: i for i, c in enumerate(coords)}
    rows: dict[str, dict[int, float]] = {}

    def row(node: str) -> dict[int, float]:
        if node not in rows:
            if node in col:
                rows[node] = {col[node]: 1.0}
            else:
                acc: dict[int, float] = {}
                for other, coef in cons[node]:
                    if other is None or coef == 0:
                        continue
                    for c, v in row(other).items():
                        acc[c] = acc.get(c, 0.0) + coef * v
                rows[node] = acc
        return rows[node]

    for n in nodes:
        row(n)
    return rows


def _group_inertias(mech: Mechanism, frames: list[str]) -> np.ndarray:
    """Per body: inertia of the rigid group containing it, referred to its speed [kg·m²].

    The group is every body driven by the same independent coordinate (frames held);
    kinetic energy ½ Σ J_b (∂θ_b/∂q)² ω_q² expressed at the speed of the body. A frame,
    or a body that moves with several coordinates, counts alone (its own inertia).
    """
    idx = mech.body_index
    frame_rows = [idx[f] for f in frames]
    # a frame that is an independent coordinate is held (a frame that moves with other
    # coordinates holds nothing: it counts alone below)
    t = mech.T.copy()
    for r in frame_rows:
        if np.count_nonzero(mech.T[r]) == 1:
            t[:, np.flatnonzero(mech.T[r])] = 0.0
    j = np.array([b.inertia for b in mech.bodies])
    # each group's inertia at its coordinate's speed, once for all the bodies in it (one
    # contiguous row per coordinate: each sum as np.sum of that column alone)
    j_q = np.ascontiguousarray((j[:, None] * t ** 2).T).sum(axis=1)
    is_frame = np.zeros(len(mech.bodies), dtype=bool)
    is_frame[frame_rows] = True
    rows = np.nonzero((np.count_nonzero(t, axis=1) == 1) & ~is_frame)[0]
    c = np.argmax(t[rows] != 0, axis=1)
    out = j.copy()
    out[rows] = j_q[c] / t[rows, c] ** 2
    return out


def _set_damping(mech: Mechanism, frames: list[str], absolute: set[str]) -> None:
    """Damping of every spring given by a ratio (``absolute``: given in N·m·s/rad)."""
    idx = mech.body_index
    inertia = _group_inertias(mech, frames)
    for s in mech.springs:
        if s.name in absolute:
            continue
        ends = [idx[b] for b in s.incidence if b in idx]
        jb = inertia[ends[1]] if len(ends) > 1 else None
        s.damping = damping_coefficient(s.stiffness, inertia[ends[0]], jb, s.damping_ratio)


def _spring(entry: Mapping[str, Any], incidence: dict[str, float], kind: str) -> Spring:
    return Spring(entry["name"], incidence, float(entry["stiffness"]),
                  float(entry.get("damping", 0.0)), kind,
                  float(entry.get("damping_ratio", 0.0)), float(entry.get("inertia", 0.0)))


def _motor(i: int, m: Mapping[str, Any]) -> Motor:
    c = m.get("controller") or {"type": "none"}
    ctrl = Controller(c["type"], c.get("sensor", ""), float(c.get("kp", 0.0)),
                      float(c.get("ki", 0.0)), float(c.get("setpoint_weight", 1.0)),
                      float(c.get("feedforward", 1.0)) if c["type"] == "torque" else 0.0)
    limit = m.get("torque_limit")
    return Motor(m["name"], m["node"], float(m.get("sign", 1)),
                 None if limit is None else float(limit), ctrl, i)


def build_chain(desc: Mapping[str, Any], where: str = "drivetrain", *,
                check: bool = True) -> Chain:
    """The mechanism, motors, sensors and excitation of a drivetrain description.

    Parameters
    ----------
    desc : mapping
        The description (docs/drivetrain.md; SI units: kg·m², N·m/rad, N·m·s/rad, N·m).
    where : str
        Key path of ``desc`` in the config, for error messages.
    check : bool, default True
        Run :func:`gbpipe.model.chain_checks.check_description` first and
        :func:`~gbpipe.model.chain_checks.check_inertia` on the mechanism. Only a caller
        whose description was checked at load may skip it (a fit's model evaluations,
        where the checks were a fifth of the cost: :func:`gbpipe.model.bench_chain`).

    Returns
    -------
    Chain

    Raises
    ------
    gbpipe.errors.ConfigError
        Naming the element's key path (``drivetrain.gears[1].parent``) and the fix.
    """
    if check:
        check_description(desc, where)
    disks = desc["disks"]
    nodes = list(disks)
    cons = constraints(desc)
    coords = [n for n in nodes if n not in cons]
    rows = _rows(nodes, coords, cons)
    planets = {p["planet"]: int(p["planets"]) for p in desc.get("planetary", [])}
    frames = list(dict.fromkeys(
        [p["ring"] for p in desc.get("planetary", []) if p["ring"] is not None]
        + [g["housing"] for g in desc.get("gears", []) if g.get("housing") is not None]))
    motor_nodes = {m["node"] for m in desc.get("motors", [])}
    gear_nodes = set(cons) | {n for g in desc.get("gears", [])
                              for n in (g["parent"], g["child"])} | {
        p["carrier"] for p in desc.get("planetary", [])}

    def kind(n: str) -> str:
        return disks[n].get("kind") or ("housing" if n in frames else "motor"
                                        if n in motor_nodes else "gear" if n in gear_nodes
                                        else "disk")

    # the planets of a stage move together in torsion: their disk inertia is per planet
    bodies = [Body(n, float(disks[n]["inertia"]) * planets.get(n, 1), kind(n))
              for n in nodes]
    T = np.zeros((len(nodes), len(coords)))
    for r, n in enumerate(nodes):
        for c, v in rows[n].items():
            T[r, c] += v
    springs = ([_spring(s, {s["between"][0]: 1.0, s["between"][1]: -1.0},
                        s.get("kind", "shaft")) for s in desc.get("shafts", [])]
               + [_spring(m, {m["node"]: 1.0}, "mount") for m in desc.get("mounts", [])]
               + [_spring(g, mesh_incidence(g), "mesh") for g in desc.get("gears", [])
                  if "stiffness" in g])
    meshes = [{"name": g["name"], "members": [g["parent"], g["child"]],
               "ratio": _ratio(g)[0]} for g in desc.get("gears", [])] + [
        {"name": p["name"], "members": [p["carrier"], p["planet"], p["sun"]],
         "ratio": 1 + p["teeth"]["ring"] / p["teeth"]["sun"]}
        for p in desc.get("planetary", [])]
    mech = Mechanism(bodies, springs, coords, T, meshes)
    if check:
        check_inertia(mech, where)
    # a mesh's damping is absolute (N·m·s/rad) or 0: no ratio rule refers it
    absolute = {s["name"] for s in [*desc.get("shafts", []), *desc.get("mounts", [])]
                if "damping" in s} | {g["name"] for g in desc.get("gears", [])
                                      if "stiffness" in g}
    _set_damping(mech, frames, absolute)
    sensors = desc.get("sensors", [])
    return Chain(
        mech, [_motor(i, m) for i, m in enumerate(desc.get("motors", []))],
        {s["name"]: s["speed"] for s in sensors if "speed" in s},
        {s["name"]: (s["torque"], float(s.get("sign", 1))) for s in sensors if "torque" in s},
        {s["name"]: s["angle"] for s in sensors if "angle" in s},
        {e["name"]: e["shaft"] for e in desc.get("excitation", [])},
        frames)
