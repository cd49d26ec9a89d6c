"""The paper's instance: a drivetrain description from the ``gearbox:`` + ``bench:`` config.

The back-to-back bench (driver motor, GB2 as reducer, LSS shaft, GB1, driven motor) and
one gearbox with free ends are *descriptions* (docs/drivetrain.md) that
:func:`gbpipe.model.chain.build_chain` turns into mechanisms, like any other chain.

Sign conventions. Every angle is positive in the direction of rotation of its own shaft
in operation; the direction reversal of external meshes is not tracked (a torsional model
only needs magnitudes of ratios). The bench's couplings and LSS shaft are listed upstream
end first in the bench's normal power flow (driver → GB2 HSS → GB2 LSS → GB1 LSS → GB1 HSS
→ driven motor), so their torques are positive in operation. A gearbox's own shafts are
listed HSS side first (as :func:`gearbox_drivetrain` lists them): upstream in GB2, the
reducer, downstream in GB1, the multiplier, whose internal shaft torques (and transmission
errors) are therefore negative in operation.

Stage inertias in the config are either one number, lumped on the stage's input member
(carrier or wheel) — the form of the paper's starting values — or a mapping of own-axis
member inertias (``{carrier, planet, sun}`` with ``planet`` per planet; ``{wheel, pinion}``).
The gear damping ratio ξ_G has no relative coordinate to act on while gears are rigid; it
is kept in the config and reported as unused, ready for a flexible-mesh extension.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.kinematics import Stage, parse_stages
from gbpipe.model.chain import Chain, build_chain
from gbpipe.model.mechanics import Mechanism

__all__ = ["paper_drivetrain", "gearbox_drivetrain", "paper_chain", "gearbox_chain",
           "gearbox_mechanism", "bench_mechanism"]


def _members(st: Stage) -> list[str]:
    return ["carrier", "planet", "sun"] if st.type == "planetary" else ["wheel", "pinion"]


def _gearbox(gb: Mapping[str, Any], stages: list[Stage], prefix: str) -> dict[str, Any]:
    """One gearbox's disks, shafts, mounts, gears and planetary stages."""
    elastic = gb["housing"]["mount"] == "elastic"
    housing = f"{prefix}housing" if elastic else None
    disks: dict[str, dict[str, Any]] = {}
    if elastic:
        disks[housing] = {"inertia": float(gb["housing"]["inertia"])}
    gears, planetary = [], []
    for i, st in enumerate(stages, start=1):
        inertia = gb["inertia"][i - 1]
        for m in _members(st):
            value = (float(inertia.get(m, 0.0)) if isinstance(inertia, Mapping)
                     else float(inertia) if m == st.input_member else 0.0)
            disks[f"{prefix}{m}{i}"] = {"inertia": value}
        name = f"{prefix}mesh{i}"
        if st.type == "planetary":
            planetary.append({"name": name, "carrier": f"{prefix}carrier{i}",
                              "planet": f"{prefix}planet{i}", "sun": f"{prefix}sun{i}",
                              "ring": housing, "teeth": dict(st.teeth),
                              "planets": st.planets})
        else:
            gear = {"name": name, "parent": f"{prefix}wheel{i}", "child": f"{prefix}pinion{i}",
                    "teeth": [st.teeth["wheel"], st.teeth["pinion"]]}
            if elastic:
                gear["housing"] = housing
            gears.append(gear)
    disks[f"{prefix}flange"] = {"inertia": float(gb["inertia"][-1])}
    xi = float(gb["damping_ratio"]["shaft"])
    shafts = []
    for i, st in enumerate(stages, start=1):
        nxt = (f"{prefix}{stages[i].input_member}{i + 1}" if i < len(stages)
               else f"{prefix}flange")
        shafts.append({"name": f"{prefix}shaft{i}",
                       "between": [nxt, f"{prefix}{st.output_member}{i}"],
                       "stiffness": float(gb["stiffness"][i - 1]), "damping_ratio": xi})
    mounts = ([{"name": f"{prefix}mount", "node": housing,
                "stiffness": float(gb["housing"]["stiffness"]),
                "damping_ratio": float(gb["housing"]["damping_ratio"])}] if elastic else [])
    return {"disks": disks, "shafts": shafts, "mounts": mounts, "gears": gears,
            "planetary": planetary}


def _coordinate_names(stages: list[Stage], prefixes: list[str]) -> dict[str, str]:
    # a stage's input member keeps its historic coordinate name (the state names of
    # results/model/*.nc): gb1.carrier1 -> gb1.stage1
    return {f"{p}{st.input_member}{i}": f"{p}stage{i}" for p in prefixes
            for i, st in enumerate(stages, start=1)}


def gearbox_drivetrain(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """Description of one gearbox free at both ends (``cfg["gearbox"]``).

    Two torque-commanded "motors", ``hss`` on the flange and ``lss`` on the first stage's
    input member, carry the end torques [N·m]; sensors ``speed_lss``, ``speed_hss``
    [rad/s], ``torque_shaft<k>`` (and ``torque_mount``) [N·m]; excitation ``te_mesh<k>``
    [rad] in the shaft after mesh k.
    """
    gb = cfg["gearbox"]
    stages = parse_stages(gb["stages"])
    desc = _gearbox(gb, stages, "")
    lss = f"{stages[0].input_member}1"
    n = len(stages)
    desc["motors"] = [{"name": "hss", "node": "flange", "sign": 1},
                      {"name": "lss", "node": lss, "sign": 1}]
    desc["sensors"] = ([{"name": "speed_lss", "speed": lss},
                        {"name": "speed_hss", "speed": "flange"}]
                       + [{"name": f"torque_shaft{i}", "torque": f"shaft{i}"}
                          for i in range(1, n + 1)]
                       + [{"name": "torque_mount", "torque": m["name"]}
                          for m in desc["mounts"]])
    desc["excitation"] = [{"name": f"te_mesh{i}", "shaft": f"shaft{i}"}
                          for i in range(1, n + 1)]
    return {"name": str(gb["name"]), **desc}


def paper_drivetrain(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """Description of the paper's back-to-back bench from ``gearbox:`` + ``bench:``.

    Returns
    -------
    dict
        The ``drivetrain:`` contract (docs/drivetrain.md, "How the paper's bench maps onto
        it"): motors ``driver`` (speed loop on ``speed_driver_motor``) and ``driven``
        (sign −1: braking; torque loop on ``torque_meter_driven``), both gearboxes, the
        couplings and LSS shaft, and today's sensors and excitation inputs.
    """
    return _paper(cfg, parse_stages(cfg["gearbox"]["stages"]))


def _paper(cfg: Mapping[str, Any], stages: list[Stage]) -> dict[str, Any]:
    """:func:`paper_drivetrain` with the stages parsed (once per model build)."""
    gb, bench = cfg["gearbox"], cfg["bench"]
    g2, g1 = _gearbox(gb, stages, "gb2."), _gearbox(gb, stages, "gb1.")
    lss = f"{stages[0].input_member}1"
    mi, cp, ls = bench["motor_inertia"], bench["coupling"], bench["lss_shaft"]
    coupling = {"stiffness": float(cp["stiffness"]), "damping_ratio": float(cp["damping_ratio"]),
                "kind": "coupling"}
    sc, tc = bench["speed_controller"], bench["torque_controller"]
    limit = bench["torque_limit"]
    n = len(stages)
    elastic = gb["housing"]["mount"] == "elastic"
    return {
        "name": f"back-to-back bench: {gb['name']}",
        "disks": {"driver_motor": {"inertia": float(mi["driver"])}, **g2["disks"],
                  **g1["disks"], "driven_motor": {"inertia": float(mi["driven"])}},
        "shafts": [{"name": "driver_coupling", "between": ["driver_motor", "gb2.flange"],
                    **coupling}, *g2["shafts"],
                   {"name": "lss_shaft", "between": [f"gb2.{lss}", f"gb1.{lss}"],
                    "stiffness": float(ls["stiffness"]),
                    "damping_ratio": float(ls["damping_ratio"]), "kind": "lss_shaft"},
                   *g1["shafts"],
                   {"name": "driven_coupling", "between": ["gb1.flange", "driven_motor"],
                    **coupling}],
        "mounts": g2["mounts"] + g1["mounts"],
        "gears": g2["gears"] + g1["gears"],
        "planetary": g2["planetary"] + g1["planetary"],
        "motors": [
            {"name": "driver", "node": "driver_motor", "sign": 1,
             "torque_limit": float(limit["driver"]),
             "controller": {"type": "speed", "sensor": "speed_driver_motor",
                            "kp": float(sc["kp"]), "ki": float(sc["ki"]),
                            "setpoint_weight": float(sc["setpoint_weight"])}},
            {"name": "driven", "node": "driven_motor", "sign": -1,
             "torque_limit": float(limit["driven"]),
             "controller": {"type": "torque", "sensor": "torque_meter_driven",
                            "kp": float(tc["kp"]), "ki": float(tc["ki"]),
                            "feedforward": float(tc["feedforward"])}}],
        "sensors": [
            {"name": "speed_driver_motor", "speed": "driver_motor"},
            {"name": "speed_gb2_hss", "speed": "gb2.flange"},
            {"name": "speed_gb2_lss", "speed": f"gb2.{lss}"},
            {"name": "speed_lss", "speed": f"gb1.{lss}"},
            {"name": "speed_gb1_hss", "speed": "gb1.flange"},
            {"name": "speed_driven_motor", "speed": "driven_motor"},
            {"name": "torque_meter_driving", "torque": "driver_coupling", "sign": 1},
            {"name": "torque_meter_driven", "torque": "driven_coupling", "sign": 1},
            {"name": "torque_lss_shaft", "torque": "lss_shaft", "sign": 1},
            *([{"name": "torque_mount_gb1", "torque": "gb1.mount", "sign": 1},
               {"name": "torque_mount_gb2", "torque": "gb2.mount", "sign": 1}]
              if elastic else []),
            {"name": "angle_gb1_hss", "angle": "gb1.flange"},
            {"name": "angle_gb2_hss", "angle": "gb2.flange"}],
        "excitation": [{"name": f"te_{g}_mesh{i}", "shaft": f"{g}.shaft{i}"}
                       for g in ("gb1", "gb2") for i in range(1, n + 1)]
        + [{"name": "misalign_gb1_coupling", "shaft": "driven_coupling"},
           {"name": "misalign_gb2_coupling", "shaft": "driver_coupling"}],
    }


def _renamed(chain: Chain, names: Mapping[str, str]) -> Chain:
    chain.mechanism.coords = [names.get(c, c) for c in chain.mechanism.coords]
    return chain


def gearbox_chain(cfg: Mapping[str, Any], check: bool = False) -> Chain:
    """:func:`gearbox_drivetrain` built (coordinates ``housing``, ``stage<k>``, ``flange``).

    ``check``: run the description checks (done once at load by
    :func:`gbpipe.config.drivetrain.check_drivetrain`; skipped in a fit's loop).
    """
    stages = parse_stages(cfg["gearbox"]["stages"])
    return _renamed(build_chain(gearbox_drivetrain(cfg), "gearbox", check=check),
                    _coordinate_names(stages, [""]))


def paper_chain(cfg: Mapping[str, Any], check: bool = False) -> Chain:
    """:func:`paper_drivetrain` built (coordinates ``gb<g>.stage<k>`` as before).

    ``check``: as in :func:`gearbox_chain`.
    """
    stages = parse_stages(cfg["gearbox"]["stages"])
    return _renamed(build_chain(_paper(cfg, stages), "gearbox", check=check),
                    _coordinate_names(stages, ["gb2.", "gb1."]))


def gearbox_mechanism(cfg: Mapping[str, Any]) -> tuple[Mechanism, dict[str, str]]:
    """The mechanism of one gearbox with free LSS and HSS ends.

    Returns
    -------
    Mechanism, dict
        The mechanism and its port bodies ``{"lss": ..., "hss": ...}``.
    """
    chain = gearbox_chain(cfg)
    return chain.mechanism, {"lss": chain.speed_sensors["speed_lss"], "hss": "flange"}


def bench_mechanism(cfg: Mapping[str, Any]) -> tuple[Mechanism, dict[str, str]]:
    """The back-to-back bench's mechanism (:func:`paper_drivetrain`).

    Returns
    -------
    Mechanism, dict
        The mechanism and named bodies: ``driver_motor``, ``gb2_hss``, ``gb2_lss``,
        ``gb1_lss``, ``gb1_hss``, ``driven_motor``.
    """
    chain = paper_chain(cfg)
    sp = chain.speed_sensors
    return chain.mechanism, {"driver_motor": "driver_motor", "gb2_hss": sp["speed_gb2_hss"],
                             "gb2_lss": sp["speed_gb2_lss"], "gb1_lss": sp["speed_lss"],
                             "gb1_hss": sp["speed_gb1_hss"], "driven_motor": "driven_motor"}
