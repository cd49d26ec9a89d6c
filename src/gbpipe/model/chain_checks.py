"""Checks of a drivetrain description, each naming the element's key path.

Run by :func:`gbpipe.model.chain.build_chain` before any matrix is built: an unknown node
or spring, a name used twice, a node constrained twice or in a constraint loop, a spring
that is not a spring (stiffness ≤ 0 N·m/rad; a mount of stiffness 0 is a damper to ground
and needs its damping in N·m·s/rad), a motor loop on the wrong kind of sensor, a
part of the chain neither grounded nor driven, a coordinate without inertia.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from gbpipe.errors import ConfigError
from gbpipe.model.mechanics import Mechanism

__all__ = ["check_description", "check_inertia"]


def _unique(items: Iterable[tuple[str, str]]) -> None:
    seen: dict[str, str] = {}
    for path, name in items:
        if name in seen:
            raise ConfigError(path, f"name '{name}' is already used by {seen[name]}; names "
                              "must be unique")
        seen[name] = path


def _node(path: str, name: Any, nodes: Mapping[str, Any]) -> None:
    if name not in nodes:
        raise ConfigError(path, f"'{name}' is not a disk of drivetrain.disks (have "
                          f"{', '.join(nodes)}); add it with its inertia in kg·m²")


def _spring(path: str, entry: Mapping[str, Any], damper: bool = False) -> None:
    """Check a spring-damper; ``damper``: stiffness 0 allowed with an absolute damping."""
    k = float(entry["stiffness"])
    if damper and k == 0:
        # a dashpot to ground (bearing losses): its damping cannot come from a ratio of
        # a stiffness it does not have
        if not float(entry.get("damping", 0.0)) > 0:
            raise ConfigError(f"{path}.damping", "a mount of stiffness 0 is a damper to "
                              "ground: give its damping (N·m·s/rad) > 0 (not damping_ratio)")
    elif not k > 0:
        raise ConfigError(f"{path}.stiffness", f"{entry['stiffness']} N·m/rad: a spring's "
                          "stiffness must be > 0 (a rigid link is a gear or one disk"
                          + ("; a damper to ground is a mount of stiffness 0)" if damper
                             else ")"))
    if "damping" in entry and "damping_ratio" in entry:
        raise ConfigError(f"{path}.damping", "give damping (N·m·s/rad) or damping_ratio "
                          "(-), not both")
    for key in ("damping", "damping_ratio"):
        if key in entry and float(entry[key]) < 0:
            raise ConfigError(f"{path}.{key}", f"{entry[key]} must be ≥ 0")


def _springs(desc: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """Every element with a twist: shafts, mounts, elastic gear meshes."""
    return [*desc.get("shafts", []), *desc.get("mounts", []),
            *(g for g in desc.get("gears", []) if "stiffness" in g)]


def _elements(desc: Mapping[str, Any], where: str) -> list[tuple[str, list[Any]]]:
    """(key path, nodes it joins) of every shaft, mount, gear and planetary stage."""
    out = [(f"{where}.shafts[{i}]", list(s["between"]))
           for i, s in enumerate(desc.get("shafts", []))]
    out += [(f"{where}.mounts[{i}]", [m["node"]]) for i, m in enumerate(desc.get("mounts", []))]
    out += [(f"{where}.gears[{i}]", [g["parent"], g["child"], g.get("housing")])
            for i, g in enumerate(desc.get("gears", []))]
    out += [(f"{where}.planetary[{i}]", [p["carrier"], p["planet"], p["sun"], p["ring"]])
            for i, p in enumerate(desc.get("planetary", []))]
    return out


def _check_links(desc: Mapping[str, Any], where: str) -> None:
    nodes = desc["disks"]
    for i, s in enumerate(desc.get("shafts", [])):
        path = f"{where}.shafts[{i}]"
        a, b = s["between"]
        _node(f"{path}.between[0]", a, nodes)
        _node(f"{path}.between[1]", b, nodes)
        if a == b:
            raise ConfigError(f"{path}.between", f"both ends are '{a}'; a shaft joins two "
                              "different disks")
        _spring(path, s)
    for i, m in enumerate(desc.get("mounts", [])):
        _node(f"{where}.mounts[{i}].node", m["node"], nodes)
        _spring(f"{where}.mounts[{i}]", m, damper=True)
    owner: dict[str, str] = {}
    for i, g in enumerate(desc.get("gears", [])):
        path = f"{where}.gears[{i}]"
        for key in ("parent", "child", "housing"):
            if g.get(key) is not None:
                _node(f"{path}.{key}", g[key], nodes)
        if g["parent"] == g["child"]:
            raise ConfigError(f"{path}.child", f"'{g['child']}' is its own parent")
        if ("teeth" in g) == ("ratio" in g):
            raise ConfigError(f"{path}.ratio", "give teeth [z_parent, z_child] or ratio "
                              "(child speed / parent speed), exactly one")
        if min(g["teeth"] if "teeth" in g else [g["ratio"]]) <= 0:
            raise ConfigError(f"{path}.{'teeth' if 'teeth' in g else 'ratio'}",
                              "must be > 0")
        if "stiffness" in g:
            _spring(path, g)          # an elastic mesh: a spring, the child free
        else:
            _constrain(owner, g["child"], f"{path}.child")
    for i, p in enumerate(desc.get("planetary", [])):
        path = f"{where}.planetary[{i}]"
        for key in ("carrier", "planet", "sun", "ring"):
            if p[key] is not None:
                _node(f"{path}.{key}", p[key], nodes)
        members = [p["carrier"], p["planet"], p["sun"], p["ring"]]
        if len(set(members)) != len(members):
            raise ConfigError(path, f"carrier, planet, sun and ring {members} must be "
                              "different disks")
        _constrain(owner, p["planet"], f"{path}.planet")
        _constrain(owner, p["sun"], f"{path}.sun")
    _no_loop(desc, owner)


def _constrain(owner: dict[str, str], node: str, path: str) -> None:
    if node in owner:
        raise ConfigError(path, f"'{node}' is already constrained by {owner[node]}; a disk "
                          "follows at most one gear mesh (make it a parent instead)")
    owner[node] = path


def _no_loop(desc: Mapping[str, Any], owner: Mapping[str, str]) -> None:
    deps: dict[str, list[str]] = {}
    for g in desc.get("gears", []):
        if "stiffness" not in g:
            deps[g["child"]] = [n for n in (g["parent"], g.get("housing")) if n is not None]
    for p in desc.get("planetary", []):
        for m in ("planet", "sun"):
            deps[p[m]] = [n for n in (p["carrier"], p["ring"]) if n is not None]
    state: dict[str, int] = {}

    def visit(n: str) -> None:
        state[n] = 1
        for d in deps.get(n, []):
            if state.get(d) == 1:
                raise ConfigError(owner[n], f"'{n}' depends on itself through the gear "
                                  "meshes; one disk of the loop must be free")
            if d not in state:
                visit(d)
        state[n] = 2

    for n in deps:
        if n not in state:
            visit(n)


def _check_io(desc: Mapping[str, Any], where: str) -> None:
    nodes = desc["disks"]
    springs = [s["name"] for s in _springs(desc)]
    kinds: dict[str, str] = {}
    for i, s in enumerate(desc.get("sensors", [])):
        found = [k for k in ("speed", "angle", "torque") if k in s]
        if len(found) != 1:
            raise ConfigError(f"{where}.sensors[{i}]", "give exactly one of speed: <disk>, "
                              "angle: <disk>, torque: <shaft or mount>")
        if found[0] == "torque":
            if s["torque"] not in springs:
                raise ConfigError(f"{where}.sensors[{i}].torque", f"'{s['torque']}' is not "
                                  f"a shaft, mount or elastic mesh (have "
                                  f"{', '.join(springs)})")
        else:
            _node(f"{where}.sensors[{i}].{found[0]}", s[found[0]], nodes)
        kinds[s["name"]] = found[0]
    for i, e in enumerate(desc.get("excitation", [])):
        if e["shaft"] not in springs:
            raise ConfigError(f"{where}.excitation[{i}].shaft", f"'{e['shaft']}' is not a "
                              f"shaft, mount or elastic mesh (have {', '.join(springs)})")
    for i, m in enumerate(desc.get("motors", [])):
        _node(f"{where}.motors[{i}].node", m["node"], nodes)
        if float(m.get("sign", 1)) not in (1.0, -1.0):
            raise ConfigError(f"{where}.motors[{i}].sign", f"{m['sign']}: use 1 or -1")
        c = m.get("controller") or {"type": "none"}
        if c["type"] == "none":
            continue
        path = f"{where}.motors[{i}].controller"
        if kinds.get(c.get("sensor")) != c["type"]:
            have = [n for n, k in kinds.items() if k == c["type"]]
            raise ConfigError(f"{path}.sensor", f"'{c.get('sensor')}' is not a {c['type']} "
                              f"sensor of drivetrain.sensors (have {', '.join(have) or 'none'})")
        for key in ("kp", "ki"):
            if float(c[key]) < 0:
                raise ConfigError(f"{path}.{key}", f"{c[key]} must be ≥ 0")


def _check_parts(desc: Mapping[str, Any], where: str) -> None:
    """Every disk linked, and every connected part grounded (a mount) or driven."""
    parent = {n: n for n in desc["disks"]}

    def root(n: str) -> str:
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    touched: set[str] = set()
    for _, linked in _elements(desc, where):
        linked = [n for n in linked if n is not None]
        touched.update(linked)
        for n in linked[1:]:
            parent[root(n)] = root(linked[0])
    for n in desc["disks"]:
        if n not in touched and len(desc["disks"]) > 1:
            raise ConfigError(f"{where}.disks.{n}", "no shaft, gear or mount reaches this "
                              "disk; link it to the chain or remove it")
    held = {root(m["node"]) for m in desc.get("mounts", [])}
    held |= {root(m["node"]) for m in desc.get("motors", [])}
    parts: dict[str, list[str]] = {}
    for n in desc["disks"]:
        parts.setdefault(root(n), []).append(n)
    for r, members in parts.items():
        if r not in held:
            raise ConfigError(f"{where}.disks", f"the part {{{', '.join(members)}}} is "
                              "neither grounded (a mount: a spring or a damper) nor driven "
                              "(a motor) and no shaft or gear links it to one that is; link "
                              "it or add a mount")


def check_description(desc: Mapping[str, Any], where: str = "drivetrain") -> None:
    """Refuse a drivetrain description that does not define one mechanism.

    Raises
    ------
    gbpipe.errors.ConfigError
        The key path of the first bad element (``drivetrain.gears[1].parent``), what is
        wrong and the fix.
    """
    disks = desc.get("disks") or {}
    if not disks:
        raise ConfigError(f"{where}.disks", "name at least one disk with its inertia (kg·m²)")
    for n, d in disks.items():
        if float(d["inertia"]) < 0:
            raise ConfigError(f"{where}.disks.{n}.inertia", f"{d['inertia']} kg·m² must be ≥ 0")
    # shafts, mounts and elastic meshes share one namespace (sensors and excitation name
    # any of them)
    _unique((f"{where}.{k}[{i}].name", s["name"])
            for k in ("shafts", "mounts", "gears") for i, s in enumerate(desc.get(k, []))
            if k != "gears" or "stiffness" in s)
    _unique((f"{where}.{k}[{i}].name", s["name"])
            for k in ("gears", "planetary") for i, s in enumerate(desc.get(k, [])))
    for key in ("motors", "sensors", "excitation"):
        _unique((f"{where}.{key}[{i}].name", s["name"]) for i, s in enumerate(desc.get(key, [])))
    _check_links(desc, where)
    _check_io(desc, where)
    _check_parts(desc, where)


def check_inertia(mech: Mechanism, where: str = "drivetrain") -> None:
    """Refuse an independent coordinate without inertia (a singular mass matrix).

    Raises
    ------
    gbpipe.errors.ConfigError
        On ``<where>.disks.<coordinate>``, with the fix.
    """
    m = mech.mass_matrix
    for i, c in enumerate(mech.coords):
        if not m[i, i] > 0:
            raise ConfigError(f"{where}.disks.{c}", "this free disk and every disk a gear "
                              "ties to it have 0 kg·m²: the mass matrix is singular; give "
                              "one of them inertia or tie it to another disk by a gear")
    try:
        np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        raise ConfigError(f"{where}.disks", f"the mass matrix over {', '.join(mech.coords)} "
                          "is singular; give the massless members inertia") from None
