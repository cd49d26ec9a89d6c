"""Frozen reference: the paper bench's construction as it was before the drivetrain
builder (gbpipe.model.drivetrain, assembly._plant and statespace.close_bench_loops at
commit 51103e3), kept only for tests/model/test_chain_paper.py. It assembles the bench's
mechanism from ``gearbox:`` + ``bench:`` directly (no description, no builder) and
closes the two PI loops by hand, so the test compares the builder's state spaces with an
independent construction. Do not import it from src/.
"""
# ruff: noqa
from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np

from gbpipe.kinematics import Stage, parse_stages
from gbpipe.lti import NamedSS
from gbpipe.model.mechanics import Body, Mechanism, Spring
from gbpipe.model.statespace import mechanism_ss




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
def close_bench_loops(plant: NamedSS, bench_cfg: Mapping[str, Any],
                      speed_gains: tuple[float, float] | None = None,
                      torque_gains: tuple[float, float] | None = None) -> NamedSS:
    """Close the bench's two PI loops around the open-loop plant.

    Driver motor (speed loop, on the driver-motor speed ``speed_driver_motor``)::

        T_driver = Kp·(b·ω_ref − ω) + Ki·∫(ω_ref − ω) dt + d_driver

    Driven motor (braking-torque loop, on the driven torque meter)::

        T_brake = ff·T_ref + Kp_t·(T_ref − T_meter) + Ki_t·∫(T_ref − T_meter) dt + d_driven

    Parameters
    ----------
    plant : NamedSS
        Open-loop bench with inputs ``motor_torque_driver``, ``motor_torque_driven``
        first, then excitation inputs.
    bench_cfg : mapping
        ``cfg["bench"]``.
    speed_gains, torque_gains : (kp, ki), optional
        Override the configured gains (used to find which gain makes a loop unstable).

    Returns
    -------
    NamedSS
        Inputs ``speed_ref`` [rad/s], ``torque_ref`` [N·m], ``disturbance_driver``,
        ``disturbance_driven`` [N·m], then the plant's excitation inputs; outputs the
        plant's outputs plus both motor torques; states the plant's plus the two
        controller integrators.
    """
    sc, tc = bench_cfg["speed_controller"], bench_cfg["torque_controller"]
    kp, ki = speed_gains or (float(sc["kp"]), float(sc["ki"]))
    kpt, kit = torque_gains or (float(tc["kp"]), float(tc["ki"]))
    b = float(sc["setpoint_weight"])
    ff = float(tc["feedforward"])
    i_drv, i_brk = plant.index("input", "motor_torque_driver"), plant.index(
        "input", "motor_torque_driven")
    exc = [i for i in range(len(plant.inputs)) if i not in (i_drv, i_brk)]
    cw = plant.C[plant.index("output", "speed_driver_motor")]
    it = plant.index("output", "torque_meter_driven")
    ct, dt_ = plant.C[it], plant.D[it, exc]
    nx, ne = plant.A.shape[0], len(exc)
    # controller outputs as linear maps of [x, z_speed, z_torque] and u_cl
    # u_cl = [speed_ref, torque_ref, d_driver, d_driven, exc...]
    nu = 4 + ne
    Kx = np.zeros((2, nx + 2))
    Ku = np.zeros((2, nu))
    Kx[0, :nx], Kx[0, nx] = -kp * cw, ki
    Ku[0, 0], Ku[0, 2] = kp * b, 1.0
    Kx[1, :nx], Kx[1, nx + 1] = -kpt * ct, kit
    Ku[1, 1], Ku[1, 3] = ff + kpt, 1.0
    Ku[1, 4:] = -kpt * dt_
    Bm = plant.B[:, [i_drv, i_brk]]
    A = np.zeros((nx + 2, nx + 2))
    A[:nx, :nx] = plant.A
    A[:nx] += Bm @ Kx
    A[nx, :nx] = -cw
    A[nx + 1, :nx] = -ct
    B = np.zeros((nx + 2, nu))
    B[:nx] = Bm @ Ku
    B[:nx, 4:] += plant.B[:, exc]
    B[nx, 0] = 1.0
    B[nx + 1, 1] = 1.0
    B[nx + 1, 4:] = -dt_
    Dm = plant.D[:, [i_drv, i_brk]]
    C = np.vstack([np.hstack([plant.C, np.zeros((len(plant.outputs), 2))]) + Dm @ Kx, Kx])
    D = np.vstack([Dm @ Ku, Ku])
    D[:len(plant.outputs), 4:] += plant.D[:, exc]
    inputs = ["speed_ref", "torque_ref", "disturbance_driver", "disturbance_driven"] + [
        plant.inputs[i] for i in exc]
    outputs = plant.outputs + ["motor_torque_driver", "motor_torque_driven"]
    states = plant.states + ["integral_speed_error", "integral_torque_error"]
    units = dict(plant.units)
    units.update(speed_ref="rad/s", torque_ref="N m", disturbance_driver="N m",
                 disturbance_driven="N m", motor_torque_driver="N m",
                 motor_torque_driven="N m", integral_speed_error="rad",
                 integral_torque_error="N m s")
    return NamedSS(A, B, C, D, states, inputs, outputs, units)

def gearbox_ss(cfg: Mapping[str, Any]) -> NamedSS:
    """State space of one gearbox, free at the LSS and HSS ends.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gbpipe.config.load``).

    Returns
    -------
    NamedSS
        Inputs ``torque_hss``, ``torque_lss`` [N·m], ``te_mesh<k>`` [rad]; outputs
        ``speed_lss``, ``speed_hss`` [rad/s], ``torque_shaft<k>`` (and ``torque_mount``)
        [N·m]; states ``angle[...]`` [rad] and ``speed[...]`` [rad/s] of the independent
        coordinates. Figure 3 is ``torque_hss → speed_lss``.
    """
    mech, ports = gearbox_mechanism(cfg)
    n = len(cfg["gearbox"]["stages"])      # parsed (validated) by gearbox_mechanism
    torques = {"torque_hss": (ports["hss"], 1.0), "torque_lss": (ports["lss"], 1.0)}
    errors = {f"te_mesh{i}": f"shaft{i}" for i in range(1, n + 1)}
    speeds = {"speed_lss": ports["lss"], "speed_hss": ports["hss"]}
    shaft_t = {f"torque_shaft{i}": (f"shaft{i}", 1.0) for i in range(1, n + 1)}
    if cfg["gearbox"]["housing"]["mount"] == "elastic":
        shaft_t["torque_mount"] = ("mount", 1.0)
    return mechanism_ss(mech, torques, errors, speeds, shaft_t)


def _plant(cfg: Mapping[str, Any]) -> NamedSS:
    mech, p = bench_mechanism(cfg)
    n = len(cfg["gearbox"]["stages"])      # parsed (validated) by bench_mechanism
    torques = {"motor_torque_driver": ("driver_motor", 1.0),
               "motor_torque_driven": ("driven_motor", -1.0)}   # braking torque
    errors: dict[str, str] = {}
    for gb in ("gb1", "gb2"):
        for i in range(1, n + 1):
            errors[f"te_{gb}_mesh{i}"] = f"{gb}.shaft{i}"
    errors["misalign_gb1_coupling"] = "driven_coupling"
    errors["misalign_gb2_coupling"] = "driver_coupling"
    speeds = {"speed_driver_motor": p["driver_motor"], "speed_gb2_hss": p["gb2_hss"],
              "speed_gb2_lss": p["gb2_lss"], "speed_lss": p["gb1_lss"],
              "speed_gb1_hss": p["gb1_hss"], "speed_driven_motor": p["driven_motor"]}
    torques_out = {"torque_meter_driving": ("driver_coupling", 1.0),
                   "torque_meter_driven": ("driven_coupling", 1.0),
                   "torque_lss_shaft": ("lss_shaft", 1.0)}
    if cfg["gearbox"]["housing"]["mount"] == "elastic":
        torques_out.update(torque_mount_gb1=("gb1.mount", 1.0),
                           torque_mount_gb2=("gb2.mount", 1.0))
    angles = {"angle_gb1_hss": p["gb1_hss"], "angle_gb2_hss": p["gb2_hss"]}
    return mechanism_ss(mech, torques, errors, speeds, torques_out, angles)


def bench_ss(cfg: Mapping[str, Any], closed: bool = True, *,
             speed_gains: tuple[float, float] | None = None,
             torque_gains: tuple[float, float] | None = None) -> NamedSS:
    """State space of the complete back-to-back bench.

    Parameters
    ----------
    cfg : mapping
        Validated configuration.
    closed : bool, default True
        Close the speed loop (driver motor) and the braking-torque loop (driven motor).
    speed_gains, torque_gains : (kp, ki), optional
        Replace the configured PI gains (e.g. zero gains open a loop for a truth model).

    Returns
    -------
    NamedSS
        Closed loop: inputs ``speed_ref`` [rad/s], ``torque_ref`` [N·m],
        ``disturbance_driver``/``disturbance_driven`` [N·m] (motor torque ripple),
        ``te_gb<g>_mesh<k>`` and ``misalign_gb<g>_coupling`` [rad] (excitation); outputs
        speeds [rad/s] of both motors, both HSS (``speed_gb1_hss``, ``speed_gb2_hss``),
        both LSS ends (``speed_lss`` is GB1's), the torque meters
        ``torque_meter_driving``/``torque_meter_driven``, the LSS shaft and mount torques
        [N·m], HSS angles [rad], and both motor torques. Open loop: the two motor torques
        replace references and disturbances.
    """
    plant = _plant(cfg)
    if not closed:
        return plant
    return close_bench_loops(plant, cfg["bench"], speed_gains, torque_gains)
