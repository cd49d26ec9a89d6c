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
  (the gear's own inertia sits on its node).

:func:`from_assembly` reads these into the description: nodes ``n0``, ``n1`` … by
openTorsion number; shafts ``shaft0`` … in openTorsion order with their absolute
``damping``; a disk's ground spring and damper a ``mounts`` entry; a mesh's ``ratio``
``R_parent/R_child``. The description counts every angle positive in its own direction
of rotation (ratios are magnitudes), openTorsion in one frame (a mesh reverses): node
``n``'s angle is ``node_directions(assembly)[n]`` (±1) times openTorsion's, a change of
variables that leaves every frequency and every energy unchanged. A loop of shafts and
meshes that needs the reversal, a damper to ground without a spring and an
``ElasticGear`` cannot be written in the description: each is refused by name, never
dropped. :func:`to_assembly` writes a description back; :func:`expand` is the config hook
``drivetrain: {opentorsion: path.py:function}``.

openTorsion is optional (``pip install gbpipe[opentorsion]``): imported only here, only
when an assembly is built or read from a file.
"""

from __future__ import annotations

import hashlib
import importlib.util
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gbpipe.errors import ConfigError
from gbpipe.model.chain import build_chain

__all__ = ["node_directions", "from_assembly", "to_assembly", "load_assembly", "expand"]

#: Where an imported assembly is named in errors.
FIELD = "drivetrain.opentorsion"
#: The description's keys that an openTorsion assembly defines.
ASSEMBLY_KEYS = ("disks", "shafts", "mounts", "gears")


def _opentorsion(field: str) -> Any:
    try:
        import opentorsion  # optional dependency
    except ImportError:
        raise ConfigError(field, "needs openTorsion, which is not installed: "
                          "pip install gbpipe[opentorsion]") from None
    return opentorsion


def _node(n: int) -> str:
    return f"n{n}"


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
    for g in assembly.gear_elements or []:
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
        Disks, shafts and rigid gears.
    field : str, default ``"drivetrain.opentorsion"``
        Key path named in errors.

    Returns
    -------
    dict
        ``{"disks", "shafts", "mounts", "gears"}``: inertia [kg·m²] per node (its disks'
        and gears'), shaft ``stiffness`` [N·m/rad], ``damping`` [N·m·s/rad] and own
        ``inertia`` [kg·m²] (only when not 0), mounts (a disk's ``k``, ``c`` to ground),
        gear meshes with their ``ratio`` [-] (child speed per parent speed, > 0).

    Raises
    ------
    ConfigError
        An element the description cannot hold, named with the fix: an ``ElasticGear``,
        a disk's damper to ground without a spring, a loop that needs a reversal
        (:func:`node_directions`).
    """
    if getattr(assembly, "elastic_gear_elements", None):
        nodes = [g.node for g in assembly.elastic_gear_elements]
        raise ConfigError(field, f"the assembly has ElasticGear elements (nodes {nodes}): "
                          "the drivetrain description has rigid meshes only; use Gear, or "
                          "model the mesh stiffness as a shaft between two nodes")
    node_directions(assembly, field)
    disks = assembly.disk_elements or []
    gears = assembly.gear_elements or []
    nodes = sorted({e.node for e in (*disks, *gears)}
                   | {n for s in assembly.shaft_elements for n in (s.nl, s.nr)})
    inertia = dict.fromkeys(nodes, 0.0)
    for d in disks:
        inertia[d.node] += float(d.I)
        if d.c and not d.k:
            raise ConfigError(field, f"the Disk on node {d.node} has a damper to ground "
                              f"(c = {d.c} N·m·s/rad) without a spring (k = 0): a "
                              "drivetrain mount needs a stiffness > 0; give the Disk a "
                              "ground stiffness k or drop its c")
    # in node order (stable): the order to_assembly writes them back in
    grounded = sorted((d for d in disks if d.k), key=lambda d: d.node)
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
    return {"disks": {_node(n): {"inertia": inertia[n]} for n in nodes},
            "shafts": shafts, "mounts": mounts, "gears": meshes}


def to_assembly(description: Mapping[str, Any], field: str = "drivetrain") -> Any:
    """An openTorsion assembly of a ``drivetrain:`` description.

    Nodes are numbered in the order of ``disks``. Each mount's ``k`` and ``c`` go on a
    disk of its node (mounts come back in node order); a gear node's inertia on its
    ``Gear``; a mesh's radii are 1 at the root of a gear tree and ``R_child =
    R_parent/ratio`` below (openTorsion reverses the child, the description does not:
    :func:`node_directions` of the result). A ``damping_ratio`` is written as the
    absolute damping the chain builder derives from it (docs/drivetrain.md).

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
    ot = _opentorsion(field)
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
    parent_of = {g["child"]: g for g in description.get("gears", [])}
    geared = set(parent_of) | {g["parent"] for g in description.get("gears", [])}
    elements: dict[str, Any] = {}

    def _gear(name: str) -> Any:
        # parents first: a child's radius follows its parent's
        if name not in elements:
            g = parent_of.get(name)
            if g is None:
                elements[name] = ot.Gear(number[name], inertia[name], 1.0)
            else:
                parent = _gear(g["parent"])
                ratio = (float(g["ratio"]) if "ratio" in g
                         else int(g["teeth"][0]) / int(g["teeth"][1]))
                elements[name] = ot.Gear(number[name], inertia[name], parent.R / ratio,
                                         parent=parent)
        return elements[name]

    gears = [_gear(n) for n in names if n in geared]
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
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=gears or None)


def load_assembly(spec: str, base: str | Path = ".", field: str = FIELD
                  ) -> tuple[Any, str]:
    """Run ``path.py:function`` and return the assembly it builds.

    Parameters
    ----------
    spec : str
        ``path/to/file.py:function``; a relative path is taken from ``base``.
    base : path-like, default the working directory
        Folder of relative paths.
    field : str
        Key path named in errors.

    Returns
    -------
    opentorsion.Assembly, str
        The assembly and the SHA-256 of the file (hex; files it imports are not
        hashed).

    Raises
    ------
    ConfigError
        Not ``file:function``; the file or the function missing; the file or the
        function failing (the error quoted); a result that is not an
        ``opentorsion.Assembly``; openTorsion not installed.
    """
    path_s, sep, func = str(spec).rpartition(":")
    if not sep or not path_s or not func.isidentifier():
        raise ConfigError(field, f"{spec!r} is not 'path/to/file.py:function'")
    ot = _opentorsion(field)
    path = Path(path_s)
    path = path if path.is_absolute() else Path(base) / path
    if not path.is_file():
        raise ConfigError(field, f"file {path} does not exist (a relative path is taken "
                          f"from {Path(base).resolve()})")
    data = path.read_bytes()
    mod_spec = importlib.util.spec_from_file_location(f"_gbpipe_ot_{path.stem}", path)
    module = importlib.util.module_from_spec(mod_spec)
    try:
        mod_spec.loader.exec_module(module)
    except Exception as exc:
        raise ConfigError(field, f"running {path} failed: {type(exc).__name__}: {exc}"
                          ) from exc
    build = getattr(module, func, None)
    if not callable(build):
        have = sorted(n for n, v in vars(module).items()
                      if callable(v) and not n.startswith("_"))
        raise ConfigError(field, f"{path} has no function {func!r}; it has {have}")
    try:
        assembly = build()
    except Exception as exc:
        raise ConfigError(field, f"{path}:{func}() failed: {type(exc).__name__}: {exc}"
                          ) from exc
    if not isinstance(assembly, ot.Assembly):
        raise ConfigError(field, f"{path}:{func}() returned {type(assembly).__name__}, "
                          "not an opentorsion.Assembly")
    return assembly, hashlib.sha256(data).hexdigest()


def expand(drivetrain: Mapping[str, Any], base: str | Path = ".",
           field: str = "drivetrain") -> dict[str, Any]:
    """The ``drivetrain:`` section with ``opentorsion: file:function`` read into it.

    The assembly's ``disks``, ``shafts``, ``mounts`` and ``gears`` join the section's own
    keys (motors, sensors, excitation), and ``opentorsion`` becomes its provenance
    ``{"source": "file:function", "sha256": …}``, so that fit key paths such as
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
        See :func:`load_assembly`; a section that gives both the file and any of
        ``disks``, ``shafts``, ``mounts``, ``gears``.
    """
    spec = drivetrain.get("opentorsion")
    if not isinstance(spec, str):
        return dict(drivetrain)
    both = [k for k in ASSEMBLY_KEYS if k in drivetrain]
    if both:
        raise ConfigError(f"{field}.{both[0]}", "given beside drivetrain.opentorsion, whose "
                          "assembly defines it: remove one of them")
    assembly, sha = load_assembly(spec, base, f"{field}.opentorsion")
    out = {k: v for k, v in drivetrain.items() if k != "opentorsion"}
    out.update(from_assembly(assembly, f"{field}.opentorsion"))
    out["opentorsion"] = {"source": spec, "sha256": sha}
    return out
