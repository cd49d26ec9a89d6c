"""openTorsion assemblies to and from the ``drivetrain:`` description (docs/drivetrain.md).

openTorsion (https://github.com/Aalto-Arotor/openTorsion) is the field's open library of
torsional lumped models. Its :class:`opentorsion.Assembly` holds numbered nodes and

* ``Disk(node, I, c, k)``: an inertia [kg·m²] with a damper ``c`` [N·m·s/rad] and a
  spring ``k`` [N·m/rad] to ground;
* ``Shaft(nl, nr, k=…, I=…, c=…)`` or ``Shaft(nl, nr, L, odl, idl, G, rho, c=…)``: a
  spring-damper between two nodes with a *consistent* mass matrix ``m·[[2, 1], [1, 2]]``
  (``m = ρ·J_p·L/6`` from the geometry, whose ``k = G·J_p/L``; ``m = I`` when ``k`` is
  given): a shaft of own inertia ``6·m``, which the description keeps as the shaft's
  ``inertia`` (:class:`gbpipe.model.mechanics.Spring`), never lumped on the nodes;
* ``Gear(node, I, R, parent)``: a rigid mesh ``R_parent·θ_parent + R_child·θ_child = 0``
  (the gear's own inertia sits on its node);
* ``ElasticGear(node, I, R, k, c, parent)``: a mesh of finite stiffness, the stiffness
  matrix ``k·g gᵀ`` with ``g = [1, R_child/R_parent]`` over (parent, child): a spring on
  the mesh's relative angle ``θ_parent + (R_child/R_parent)·θ_child``, zero where the rigid
  mesh's constraint holds, its torque referred to the parent (damping ``c`` alike).

:func:`from_assembly` reads these into the description: nodes ``n0``, ``n1`` … by
openTorsion number; shafts ``shaft0`` … in openTorsion order with their absolute
``damping``; a disk's ground spring and damper a ``mounts`` entry (stiffness 0: a damper to
ground); a mesh's ``ratio`` ``R_parent/R_child``, an elastic mesh's with its ``stiffness``
and ``damping`` (:func:`gbpipe.model.chain.mesh_incidence`). The description counts every
angle positive in its own direction of rotation (ratios are magnitudes), openTorsion in
one frame (a mesh reverses): node ``n``'s angle is ``node_directions(assembly)[n]`` (±1)
times openTorsion's, a change of variables that leaves every frequency and every energy
unchanged. A loop of shafts and meshes that needs the reversal cannot be written in the
description: it is refused by name, never dropped. :func:`to_assembly` writes a
description back, :func:`export` to a TORS or Python model file; :func:`expand` is the
config hook ``drivetrain: {opentorsion: model.json | path.py:function}``
(:mod:`gbpipe.model.opentorsion_files`).

openTorsion is optional (``pip install gbpipe[opentorsion]``): imported only here, only
when an assembly is built or read from a file.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gbpipe.errors import ConfigError
from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_files import (
    import_opentorsion,
    load_model_file,
    read_tors,
    write_model_file,
    write_tors,
)

__all__ = ["node_directions", "from_assembly", "to_assembly", "expand", "export"]

#: Where an imported assembly is named in errors.
FIELD = "drivetrain.opentorsion"
#: The description's keys that an openTorsion assembly defines.
ASSEMBLY_KEYS = ("disks", "shafts", "mounts", "gears")


def _node(n: int) -> str:
    return f"n{n}"


def _gears(assembly: Any) -> list[Any]:
    """The rigid gears, then the elastic ones (both reverse the child)."""
    return [*(assembly.gear_elements or []), *(assembly.elastic_gear_elements or [])]


def node_directions(assembly: Any, field: str = FIELD) -> dict[str, int]:
    """Direction of each node's angle in the description relative to openTorsion's.

    A rigid mesh reverses the direction of rotation; the description counts every angle
    positive in its own direction, so a node beyond an odd number of meshes has the sign
    −1 (shafts keep it, ground is angle 0 in either direction).

    Parameters
    ----------
    assembly : opentorsion.Assembly
    field : str
        Key path named in errors.

    Returns
    -------
    dict
        Node name (``n<k>``) → +1 or −1 [-].

    Raises
    ------
    ConfigError
        A loop of shafts and meshes whose reversal a magnitude ratio cannot hold (the
        mesh that closes it is named).
    """
    edges: dict[int, list[tuple[int, int, str]]] = {}
    for i, s in enumerate(assembly.shaft_elements):
        edges.setdefault(s.nl, []).append((s.nr, 1, f"shaft {i}"))
        edges.setdefault(s.nr, []).append((s.nl, 1, f"shaft {i}"))
    for g in _gears(assembly):
        edges.setdefault(g.node, [])
        if g.parent is not None:
            what = f"the Gear on node {g.node} (parent node {g.parent.node})"
            edges[g.node].append((g.parent.node, -1, what))
            edges.setdefault(g.parent.node, []).append((g.node, -1, what))
    for d in assembly.disk_elements or []:
        edges.setdefault(d.node, [])
    sign: dict[int, int] = {}
    for root in sorted(edges):
        if root in sign:
            continue
        sign[root], todo = 1, [root]
        while todo:
            n = todo.pop()
            for m, flip, what in edges[n]:
                if m not in sign:
                    sign[m] = flip * sign[n]
                    todo.append(m)
                elif sign[m] != flip * sign[n]:
                    raise ConfigError(field, f"{what} closes a loop of shafts and meshes "
                                      "that turns a node both ways: the description's "
                                      "gear ratios are magnitudes and cannot hold it; "
                                      "break the loop (e.g. the shaft that closes it)")
    return {_node(n): v for n, v in sorted(sign.items())}


def from_assembly(assembly: Any, field: str = FIELD) -> dict[str, Any]:
    """The ``drivetrain:`` description of an openTorsion assembly.

    Parameters
    ----------
    assembly : opentorsion.Assembly
        Disks, shafts, rigid and elastic gears.
    field : str, default ``"drivetrain.opentorsion"``
        Key path named in errors.

    Returns
    -------
    dict
        ``{"disks", "shafts", "mounts", "gears"}``: inertia [kg·m²] per node (its disks'
        and gears'), shaft ``stiffness`` [N·m/rad], ``damping`` [N·m·s/rad] and own
        ``inertia`` [kg·m²] (only when not 0), mounts (a disk's ``k``, ``c`` to ground;
        ``k = 0``: a damper to ground), gear meshes with their ``ratio`` [-] (child speed
        per parent speed, > 0), the rigid ones first, then the elastic ones with their
        ``stiffness`` [N·m/rad] and ``damping`` [N·m·s/rad].

    Raises
    ------
    ConfigError
        A loop that needs a reversal (:func:`node_directions`).
    """
    node_directions(assembly, field)
    disks = assembly.disk_elements or []
    gears = _gears(assembly)
    nodes = sorted({e.node for e in (*disks, *gears)}
                   | {n for s in assembly.shaft_elements for n in (s.nl, s.nr)})
    inertia = dict.fromkeys(nodes, 0.0)
    for d in disks:
        inertia[d.node] += float(d.I)
    # in node order (stable): the order to_assembly writes them back in
    grounded = sorted((d for d in disks if d.k or d.c), key=lambda d: d.node)
    mounts = [{"name": f"mount{i}", "node": _node(d.node), "stiffness": float(d.k),
               "damping": float(d.c)} for i, d in enumerate(grounded)]
    for g in gears:
        inertia[g.node] += float(g.I)
    shafts = []
    for i, s in enumerate(assembly.shaft_elements):
        entry = {"name": f"shaft{i}", "between": [_node(s.nl), _node(s.nr)],
                 "stiffness": float(s.k), "damping": float(s.c)}
        if s.mass:
            # openTorsion's consistent mass m·[[2, 1], [1, 2]] is a shaft of inertia 6·m
            entry["inertia"] = 6.0 * float(s.mass)
        shafts.append(entry)
    # openTorsion's mesh R_p·θ_p + R_c·θ_c = 0: the speed ratio R_p/R_c, reversed
    meshes = [{"name": f"gear{i}", "parent": _node(g.parent.node), "child": _node(g.node),
               "ratio": float(g.parent.R) / float(g.R)}
              for i, g in enumerate(g for g in gears if g.parent is not None)]
    elastic = [g for g in assembly.elastic_gear_elements or [] if g.parent is not None]
    for m, g in zip(meshes[len(meshes) - len(elastic):], elastic, strict=True):
        # ElasticGear's k·g gᵀ, g = [1, R_c/R_p]: the description's elastic mesh
        m.update(stiffness=float(g.k), damping=float(g.c))
    return {"disks": {_node(n): {"inertia": inertia[n]} for n in nodes},
            "shafts": shafts, "mounts": mounts, "gears": meshes}


def to_assembly(description: Mapping[str, Any], field: str = "drivetrain") -> Any:
    """An openTorsion assembly of a ``drivetrain:`` description.

    Nodes are numbered in the order of ``disks``. Each mount's ``k`` and ``c`` go on a
    disk of its node (mounts come back in node order; a damper to ground is a disk with
    ``k = 0``); a rigid gear node's inertia on its ``Gear``; a mesh's radii are 1 at the
    root of a gear tree and ``R_child = R_parent/ratio`` below (openTorsion reverses the
    child, the description does not: :func:`node_directions` of the result). An elastic
    mesh is an ``ElasticGear`` on its child (``k``, ``c``), its parent the parent node's
    ``Gear`` or an ``ElasticGear`` of radius 1 without inertia (their nodes' inertia on
    disks). A ``damping_ratio`` is written as the absolute damping the chain builder
    derives from it (docs/drivetrain.md).

    Parameters
    ----------
    description : mapping
        ``disks``, ``shafts``, ``mounts``, ``gears`` (a ``ratio`` or ``teeth``) as in
        docs/drivetrain.md; motors, sensors and excitation are signals, not elements,
        and are not written.
    field : str
        Key path named in errors.

    Returns
    -------
    opentorsion.Assembly

    Raises
    ------
    ConfigError
        openTorsion is not installed; an entry openTorsion 0.3 cannot hold (a planetary
        stage, a gear in a rotating housing); the chain builder's refusals.
    """
    ot = import_opentorsion(field)
    if description.get("planetary"):
        raise ConfigError(f"{field}.planetary", "openTorsion 0.3 has no planetary stage")
    for i, g in enumerate(description.get("gears", [])):
        if g.get("housing") is not None:
            raise ConfigError(f"{field}.gears[{i}].housing", "openTorsion 0.3 has no gear "
                              "in a rotating housing (its meshes have fixed bearings)")
    springs = [*description.get("shafts", []), *description.get("mounts", [])]
    damping = {e["name"]: float(e.get("damping", 0.0)) for e in springs}
    if any("damping_ratio" in e for e in springs):
        # the one rule that turns a ratio into N·m·s/rad: the chain builder's
        damping = {s.name: s.damping for s in build_chain(description, field).mechanism.springs}
    names = list(description["disks"])
    number = {n: i for i, n in enumerate(names)}
    inertia = {n: float(description["disks"][n]["inertia"]) for n in names}
    mounts: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    for m in description.get("mounts", []):
        mounts[m["node"]].append((float(m["stiffness"]), damping[m["name"]]))
    rigid = [g for g in description.get("gears", []) if "stiffness" not in g]
    parent_of = {g["child"]: g for g in rigid}
    geared = set(parent_of) | {g["parent"] for g in rigid}
    elements: dict[str, Any] = {}

    def _gear(name: str) -> Any:
        # parents first: a child's radius follows its parent's
        if name not in elements:
            g = parent_of.get(name)
            if g is None:
                elements[name] = ot.Gear(number[name], inertia[name], 1.0)
            else:
                parent = _gear(g["parent"])
                elements[name] = ot.Gear(number[name], inertia[name],
                                         parent.R / _ratio(g), parent=parent)
        return elements[name]

    gears = [_gear(n) for n in names if n in geared]
    holders: dict[str, Any] = {}
    elastic = []
    for g in description.get("gears", []):
        if "stiffness" in g:
            p = g["parent"]
            if p in geared:
                parent = elements[p]
            else:
                # ElasticGear needs a parent object with a radius: one without inertia
                parent = holders.setdefault(p, ot.ElasticGear(number[p], 0.0, 1.0))
            elastic.append(ot.ElasticGear(number[g["child"]], 0.0, parent.R / _ratio(g),
                                          k=float(g["stiffness"]),
                                          c=float(g.get("damping", 0.0)), parent=parent))
    disks = []
    for n in names:
        # a node's inertia on its first disk (a gear node's on its Gear), one disk per mount
        ground = mounts[n] or ([] if n in geared else [(0.0, 0.0)])
        disks += [ot.Disk(number[n], 0.0 if n in geared or i else inertia[n], c=c, k=k)
                  for i, (k, c) in enumerate(ground)]
    shafts = [ot.Shaft(number[s["between"][0]], number[s["between"][1]],
                       k=float(s["stiffness"]), I=float(s.get("inertia", 0.0)) / 6.0,
                       c=damping[s["name"]])
              for s in description["shafts"]]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=gears or None,
                       elastic_gear_elements=[*holders.values(), *elastic] or None)


def _ratio(gear: Mapping[str, Any]) -> float:
    """A mesh's child speed per parent speed [-], from its ratio or teeth."""
    return (float(gear["ratio"]) if "ratio" in gear
            else int(gear["teeth"][0]) / int(gear["teeth"][1]))


def expand(drivetrain: Mapping[str, Any], base: str | Path = ".",
           field: str = "drivetrain") -> dict[str, Any]:
    """The ``drivetrain:`` section with ``opentorsion: model.json | file.py:function``
    read into it (a TORS model by openTorsion's parser, executing nothing; a Python
    model file run as a script: :mod:`gbpipe.model.opentorsion_files`).

    The assembly's ``disks``, ``shafts``, ``mounts`` and ``gears`` join the section's own
    keys (motors, sensors, excitation), and ``opentorsion`` becomes its provenance
    ``{"source": <the spec>, "sha256": <the file's>}``, so that fit key paths such as
    ``drivetrain.shafts[8].stiffness`` address the expanded description and a second
    validation keeps them.

    Parameters
    ----------
    drivetrain : mapping
        The section (not modified).
    base : path-like
        Folder of a relative file path.
    field : str
        Key path of the section, for errors.

    Returns
    -------
    dict
        The expanded section; a shallow copy of the section when it names no file.

    Raises
    ------
    ConfigError
        See :func:`~gbpipe.model.opentorsion_files.load_model_file` and
        :func:`~gbpipe.model.opentorsion_files.read_tors`; a section that gives both the
        file and any of ``disks``, ``shafts``, ``mounts``, ``gears``.
    """
    spec = drivetrain.get("opentorsion")
    if not isinstance(spec, str):
        return dict(drivetrain)
    both = [k for k in ASSEMBLY_KEYS if k in drivetrain]
    if both:
        raise ConfigError(f"{field}.{both[0]}", "given beside drivetrain.opentorsion, whose "
                          "assembly defines it: remove one of them")
    read = read_tors if spec.lower().endswith(".json") else load_model_file
    assembly, sha = read(spec, base, f"{field}.opentorsion")
    out = {k: v for k, v in drivetrain.items() if k != "opentorsion"}
    out.update(from_assembly(assembly, f"{field}.opentorsion"))
    out["opentorsion"] = {"source": spec, "sha256": sha}
    return out


def export(description: Mapping[str, Any], path: str | Path, field: str = "drivetrain"
           ) -> None:
    """Write a ``drivetrain:`` description as an openTorsion model file.

    ``*.json``: TORS (:func:`~gbpipe.model.opentorsion_files.write_tors`: what TORS
    cannot hold is refused by name); ``*.py``: a Python model file whose function
    ``assembly()`` rebuilds it (every element kind). Either reads back through
    ``drivetrain: {opentorsion: …}`` and opens in openTorsion.

    Parameters
    ----------
    description : mapping
        The section (docs/drivetrain.md), e.g. a config's ``drivetrain`` with a fit's
        overlay merged.
    path : path-like
        The file to write; its suffix chooses the format.
    field : str
        Key path of the section, for errors.

    Raises
    ------
    ConfigError
        Another suffix; see :func:`to_assembly` and the writers.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in (".json", ".py"):
        raise ConfigError(field, f"cannot write {path}: give a .json (TORS) or .py "
                          "(Python model file) path")
    assembly = to_assembly(description, field)
    if suffix == ".json":
        write_tors(assembly, path, str(description.get("name") or "drivetrain"), field)
    else:
        write_model_file(assembly, path)
