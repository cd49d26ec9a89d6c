"""Cross-field checks of the gearbox: stage teeth, list lengths, cycle and mesh names.

Planetary stages are checked as a gear designer would (docs/architecture.md, "Physics"):

* **assembly**: ``planets`` planets can be equally spaced only if ``(ring + sun) /
  planets`` is an integer;
* **concentricity**: sun and ring mesh with the same planet on one axis, so ``ring = sun +
  2·planet`` for standard gears; profile shift lets a real design deviate by a few teeth
  (the paper's stages differ by 2 and 3 teeth: 96 − 24 − 2·35 = 2, 114 − 21 − 2·45 = 3).
  More than :data:`MAX_TOOTH_MISMATCH` teeth cannot be absorbed by profile shift: the
  centre distances would differ by more than one module and a half;
* **neighbouring planets** must not collide: their tip circles (``planet + 2`` modules)
  must fit in the chord ``(sun + planet)·sin(π / planets)`` between their centres.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from gbpipe import kinematics
from gbpipe.config.schema_validation import suggest
from gbpipe.errors import ConfigError

__all__ = ["MAX_TOOTH_MISMATCH", "TEETH", "MEMBERS", "check_gearbox", "check_cycle_names"]

#: Largest |ring − sun − 2·planet| [teeth] that profile shift covers (paper: 2 and 3).
MAX_TOOTH_MISMATCH = 3

#: Keys of a stage besides ``type``.
TEETH = {"planetary": ("ring", "planet", "sun", "planets"), "parallel": ("wheel", "pinion")}

#: Own-axis members whose inertia a mapping entry of ``gearbox.inertia`` may give.
MEMBERS = {"planetary": ("carrier", "planet", "sun"), "parallel": ("wheel", "pinion")}


def _collide(sun: int, planet: int, n: int) -> bool:
    # tip circle of a planet (planet + 2 modules) against the chord between two neighbours
    return n > 1 and planet + 2 >= (sun + planet) * math.sin(math.pi / n)


def _planetary(i: int, st: Mapping[str, Any]) -> None:
    ring, sun, planet, n = st["ring"], st["sun"], st["planet"], st["planets"]
    where = f"gearbox.stages[{i}]"
    share = (ring + sun) / n
    if (ring + sun) % n:
        fits = [k for k in range(2, 13) if (ring + sun) % k == 0
                and not _collide(sun, planet, k)]
        raise ConfigError(
            f"{where}.ring",
            f"{ring} teeth with sun {sun} and {n} planets: (ring+sun)/planets = {share:.4g} is "
            f"not an integer, so {n} planets cannot be equally spaced; use "
            f"{' or '.join(map(str, fits)) or 'another number of'} planets or change ring/sun")
    gap = ring - sun - 2 * planet
    if abs(gap) > MAX_TOOTH_MISMATCH:
        raise ConfigError(
            f"{where}.planet",
            f"{planet} teeth with ring {ring} and sun {sun}: ring − sun − 2·planet = {gap}, "
            f"beyond the ±{MAX_TOOTH_MISMATCH} teeth profile shift can absorb, so sun and ring "
            f"cannot both mesh with the planet on one axis; use planet ≈ {(ring - sun) / 2:g}")
    if _collide(sun, planet, n):
        raise ConfigError(
            f"{where}.planets",
            f"{n} planets of {planet} teeth around a sun of {sun} collide (tip diameter "
            f"{planet + 2} modules > spacing {(sun + planet) * math.sin(math.pi / n):.1f}); "
            "use fewer planets")


def check_gearbox(cfg: Mapping[str, Any]) -> int:
    """Check stages, inertias, stiffnesses and excited meshes; return the stage count.

    Raises
    ------
    ConfigError
        Naming the key path, the value and what would be valid.
    """
    gb = cfg["gearbox"]
    try:
        stages = kinematics.parse_stages(gb["stages"])
    except ValueError as exc:
        # kinematics messages start with the key path ("gearbox.stages[0].ring: ...")
        field, _, problem = str(exc).partition(": ")
        raise ConfigError(field, problem or str(exc)) from None
    for i, st in enumerate(gb["stages"]):
        if st["type"] == "planetary":
            _planetary(i, st)
        extra = sorted(set(st) - {"type", *TEETH[st["type"]]})
        if extra:
            raise ConfigError(f"gearbox.stages[{i}].{extra[0]}",
                              f"a {st['type']} stage has no '{extra[0]}'; "
                              f"{suggest(extra[0], ['type', *TEETH[st['type']]])}")
    n = len(stages)
    if len(gb["inertia"]) != n + 1:
        raise ConfigError("gearbox.inertia", f"has {len(gb['inertia'])} entries; a gearbox "
                          f"with {n} stages needs {n + 1} (one per stage group, then the HSS "
                          "flange) in kg·m²")
    if len(gb["stiffness"]) != n:
        raise ConfigError("gearbox.stiffness", f"has {len(gb['stiffness'])} entries; a gearbox "
                          f"with {n} stages needs {n} (the shaft after each stage) in N·m/rad")
    for i, entry in enumerate(gb["inertia"][:n]):
        if isinstance(entry, Mapping):
            allowed = MEMBERS[stages[i].type]
            bad = sorted(set(entry) - set(allowed))
            if bad:
                raise ConfigError(f"gearbox.inertia[{i}].{bad[0]}",
                                  f"not a member of a {stages[i].type} stage; "
                                  f"{suggest(bad[0], allowed)}")
            if sum(entry.values()) <= 0:
                raise ConfigError(f"gearbox.inertia[{i}]",
                                  f"total inertia {sum(entry.values())} kg·m² must be > 0")
    if isinstance(gb["inertia"][n], Mapping):
        raise ConfigError(f"gearbox.inertia[{n}]", "the HSS flange takes one number (kg·m²)")
    for i, m in enumerate(cfg["excitation"]["mesh"]):
        if m["stage"] > n:
            raise ConfigError(f"excitation.mesh[{i}].stage", f"stage {m['stage']} does not "
                              f"exist in a {n}-stage gearbox; use 1 .. {n}")
    return n


def check_cycle_names(cfg: Mapping[str, Any]) -> None:
    """Every TSA cycle must be a shaft, member or mesh of this gearbox; names unique."""
    tsa = cfg["tsa"]
    names = [v["name"] for v in tsa["variants"]]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise ConfigError(f"tsa.variants[{i}].name",
                              f"'{name}' is used twice; variant names must be unique")
    named = [(f"tsa.variants[{i}].cycles[{j}]", c) for i, v in enumerate(tsa["variants"])
             for j, c in enumerate(v["cycles"])]
    named += [(f"tsa.tests[{j}]", c) for j, c in enumerate(tsa["tests"])]
    # removal.tests: when absent it is derived from tsa.tests after this check
    named += [(f"removal.tests[{j}]", c)
              for j, c in enumerate(cfg["removal"].get("tests", []))]
    stages = cfg["gearbox"]["stages"]
    for field, cycle in named:
        try:
            kinematics.order_of(stages, cycle)
        except ValueError as exc:
            raise ConfigError(field, str(exc)) from None
