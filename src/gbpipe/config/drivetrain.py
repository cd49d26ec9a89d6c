"""Checks of the drivetrain the models are built from, at load.

With a ``drivetrain:`` section, its description (docs/drivetrain.md) is checked element
by element (:func:`gbpipe.model.chain_checks.check_description`: each error names the
key path, e.g. ``drivetrain.gears[1].parent``); without one, the paper's bench generated
from ``gearbox:`` + ``bench:`` is checked the same way, once, so that the models built
later (a fit builds one per evaluation) may skip the checks.

A section that imports its elements (``opentorsion: file.py:function``) is read here
first (:func:`expand_section`): the assembly defines the elements, and ``disks``,
``shafts``, ``mounts`` or ``gears`` beside it are values of those elements, as the fit's
overlay (``results/fit/<record>.yaml``) writes them; one that changes an element (a name,
the nodes it joins, how many there are) is refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.errors import ConfigError
from gbpipe.model.chain import build_chain
from gbpipe.model.drivetrain import gearbox_chain, paper_chain
from gbpipe.model.opentorsion_io import ASSEMBLY_KEYS, expand

__all__ = ["check_drivetrain", "expand_section", "STRUCTURE_KEYS"]

#: Keys of an element that say what it is and where it sits, not how stiff or heavy.
STRUCTURE_KEYS = ("name", "between", "node", "parent", "child", "carrier", "planet", "sun",
                  "ring", "housing", "teeth", "planets")


def _values_onto(elements: Any, given: Any, field: str) -> Any:
    """``given`` laid onto the assembly's ``elements``: its numbers replace theirs."""
    if isinstance(elements, Mapping):          # disks: name -> {inertia}, merged by name
        if not isinstance(given, Mapping):
            raise ConfigError(field, "must be a mapping of the assembly's disks")
        out = {k: dict(v) for k, v in elements.items()}
        for name, entry in given.items():
            if name not in out:
                raise ConfigError(f"{field}.{name}", "is not a node of the assembly of "
                                  f"drivetrain.opentorsion (nodes {', '.join(out)}): its "
                                  "elements come from the file; change them there")
            if not isinstance(entry, Mapping):
                raise ConfigError(f"{field}.{name}", f"{entry!r}: give a mapping, e.g. "
                                  "{inertia: 0.3} (kg·m²)")
            out[name].update(entry)
        return out
    if not isinstance(given, list):
        raise ConfigError(field, f"{given!r} beside drivetrain.opentorsion: give the whole "
                          "list of the assembly's elements with the values to change, as a "
                          "fit's overlay writes it")
    if len(given) != len(elements):
        raise ConfigError(field, f"{len(given)} entries beside drivetrain.opentorsion, whose "
                          f"assembly has {len(elements)}: beside the file only the values of "
                          "its elements may be given (as a fit's overlay does, the whole "
                          "list); add or remove elements in the file")
    out = []
    for i, (have, entry) in enumerate(zip(elements, given, strict=True)):
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{field}[{i}]", f"{entry!r}: give a mapping of the element's "
                              f"keys ({', '.join(have)})")
        for key in STRUCTURE_KEYS:
            if key in entry and entry[key] != have.get(key):
                raise ConfigError(f"{field}[{i}].{key}", f"{entry[key]!r} differs from the "
                                  f"assembly's {have.get(key)!r} (drivetrain.opentorsion "
                                  "defines the elements; beside it only their values may be "
                                  "given): change the element in the file")
        out.append({**have, **entry})
    return out


def expand_section(section: Mapping[str, Any], field: str = "drivetrain") -> dict[str, Any]:
    """The ``drivetrain:`` section with ``opentorsion: file:function`` read into it.

    The assembly's elements first (:func:`gbpipe.model.opentorsion_io.expand`), then the
    section's own ``disks``/``shafts``/``mounts``/``gears`` as values on them: a disk by
    name (its keys replace the assembly's), a list entry by position with the same
    :data:`STRUCTURE_KEYS` (its numbers replace the assembly's). So a fitted overlay of
    an imported chain reruns it, and a second validation keeps the values.

    Raises
    ------
    ConfigError
        See :func:`~gbpipe.model.opentorsion_io.expand`; an entry beside the file that
        changes an element (``drivetrain.shafts[2].between``), names a node the assembly
        lacks (``drivetrain.disks.<name>``) or changes the number of elements.
    """
    if not isinstance(section.get("opentorsion"), str):
        return dict(section)
    given = {k: section[k] for k in ASSEMBLY_KEYS if k in section}
    out = expand({k: v for k, v in section.items() if k not in given}, field=field)
    for key, value in given.items():
        out[key] = _values_onto(out[key], value, f"{field}.{key}")
    return out


def check_drivetrain(cfg: Mapping[str, Any]) -> None:
    """Build the configured drivetrain (or the paper's) with every check.

    Raises
    ------
    gbpipe.errors.ConfigError
        Naming the element's key path, what is wrong and the fix.
    """
    if cfg.get("drivetrain"):
        for node in cfg["drivetrain"]["disks"]:
            # a fit frees drivetrain.disks.<node>.inertia by key path: '.' and '[]' split it
            if any(ch in node for ch in ".[]") or not node.strip():
                raise ConfigError(f"drivetrain.disks.{node}", "a disk name may not be empty "
                                  "or hold '.', '[' or ']' (key paths such as "
                                  "drivetrain.disks.<name>.inertia split there); use '_'")
        build_chain(cfg["drivetrain"], "drivetrain")
    else:
        paper_chain(cfg, check=True)
    gearbox_chain(cfg, check=True)
