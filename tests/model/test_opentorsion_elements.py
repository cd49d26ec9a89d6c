"""Every element of openTorsion 0.3 read into the one mechanics core, against openTorsion.

The references are openTorsion's own: the assemblies its package ships (the models of its
test module, recorded as they are built), its element matrices, its ``modal_analysis``.
Dampers to ground (``Disk(node, I, c)``) and elastic meshes (``ElasticGear``) are checked
matrix by matrix and mode by mode; the stability rules on a chain held only by dampers.
"""

from __future__ import annotations

import unittest

import numpy as np
import opentorsion as ot
import opentorsion.tests.tests as shipped
import pytest

from gbpipe.errors import ConfigError, UnstableGain
from gbpipe.lti import frf
from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_io import from_assembly, node_directions, to_assembly
from gbpipe.model.stability import check_stability
from gbpipe.model.statespace import chain_plant, close_loops, mechanism_ss


def _shipped() -> list[tuple[str, ot.Assembly]]:
    """Every assembly openTorsion's own test module builds, by test name."""
    made: list[tuple[str, ot.Assembly]] = []
    current = [""]

    class Recording(ot.Assembly):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append((current[0], self))

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shipped, "Assembly", Recording)
        for name in unittest.defaultTestLoader.getTestCaseNames(shipped.Test):
            current[0] = name
            shipped.Test(name).run(unittest.TestResult())
    # rebuilt from their elements: a test may edit a built assembly's K afterwards
    return [(f"{name}[{i}]", ot.Assembly(a.shaft_elements, disk_elements=a.disk_elements,
                                          gear_elements=a.gear_elements))
            for i, (name, a) in enumerate(made)]


SHIPPED = _shipped()


def poles(desc: dict) -> np.ndarray:
    """Poles [rad/s] of the chain built from a description (states: angles, speeds)."""
    return np.linalg.eigvals(mechanism_ss(build_chain(desc).mechanism, {}, {}, {}, {}).A)


def ot_poles(asm: ot.Assembly, c: np.ndarray | None = None) -> np.ndarray:
    """openTorsion's ``modal_analysis`` as poles ``−ζ·ω_n + j·ω_d`` [rad/s] (rigid: 0)."""
    wn, wd, zeta = (np.asarray(x) for x in asm.modal_analysis(C=c))
    return np.where(wn > 0, -np.nan_to_num(zeta) * wn + 1j * wd, 0.0)


def assert_same_poles(got: np.ndarray, asm: ot.Assembly, rtol: float = 1e-9) -> None:
    """Each pole matched to the nearest of openTorsion's within ``rtol`` of its size, or
    within the round-off of any eigen-solver on openTorsion's state matrix ``A``
    (``eps·‖A‖₂``: a slow pole, e.g. a line held by dampers only, is known no better);
    the poles at 0 (rigid-body, split by round-off to ±1e-9 of the largest) counted."""
    want = ot_poles(asm)
    m, k, c = asm.M, asm.K, asm.C
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    floor = np.finfo(float).eps * np.linalg.norm(a, 2)
    small = 1e-7 * np.abs(want).max()
    got, want = got[np.abs(got) > small], want[np.abs(want) > small]
    assert got.size == want.size
    for p in got:
        assert np.abs(want - p).min() <= max(rtol * abs(p), floor), p


def free(desc: dict) -> dict:
    """A description with a torque-commanded motor on its first node (the description
    wants every part grounded or driven; a motor adds no element)."""
    return {**desc, "motors": [{"name": "drive", "node": next(iter(desc["disks"]))}]}


@pytest.mark.parametrize("name, asm", SHIPPED, ids=[n for n, _ in SHIPPED])
def test_shipped_assemblies_match_opentorsion(name, asm):
    desc = free(from_assembly(asm))
    if np.linalg.matrix_rank(asm.M) < asm.M.shape[0]:
        # a shaft end without inertia: openTorsion cannot invert M either
        with pytest.raises(ConfigError, match="disks"):
            build_chain(desc)
        with pytest.raises(np.linalg.LinAlgError):
            asm.modal_analysis()
        return
    assert_same_poles(poles(desc), asm)
    # undamped: openTorsion without damping, the core's frequencies (rigid modes dropped)
    ref = ot_poles(asm, np.zeros_like(asm.M))
    ref = np.sort(ref.imag[ref.imag > 1e-7 * np.abs(ref).max()])
    np.testing.assert_allclose(build_chain(desc).mechanism.undamped_frequencies(),
                               ref / (2 * np.pi), rtol=1e-9)


def test_shipped_assemblies_cover_the_elements():
    # geometric and stiffness shafts, gears in a branched tree, dampers to ground
    kinds = {"geometric": 0, "gear": 0, "damper": 0, "branch": 0}
    for _, asm in SHIPPED:
        kinds["geometric"] += any(s.odl for s in asm.shaft_elements)
        kinds["gear"] += bool(asm.gear_elements)
        kinds["damper"] += any(d.c and not d.k for d in asm.disk_elements or [])
        parents = [g.parent.node for g in asm.gear_elements or [] if g.parent]
        kinds["branch"] += len(parents) > len(set(parents))
    assert all(kinds.values()), kinds


def elastic_chain(seed: int) -> ot.Assembly:
    """Motor, coupling, an elastic mesh, a rigid mesh, a load; dampers to ground on the
    bearings (no spring to ground: the line turns freely). Values ±20 % with the seed."""
    rng = np.random.default_rng(seed)

    def v(x: float) -> float:
        return float(x * rng.uniform(0.8, 1.2))

    disks = [ot.Disk(0, v(0.5), c=v(0.02)), ot.Disk(1, v(0.05)), ot.Disk(3, v(0.3), c=v(0.05)),
             ot.Disk(4, v(0.02)), ot.Disk(6, v(2.0), c=v(0.4))]
    pinion = ot.ElasticGear(1, v(0.01), 20.0)
    wheel = ot.ElasticGear(2, v(0.2), v(70.0), k=v(3.0e5), c=v(4.0), parent=pinion)
    g1 = ot.Gear(4, v(0.01), 25.0)
    g2 = ot.Gear(5, v(0.15), v(80.0), parent=g1)
    shafts = [ot.Shaft(0, 1, k=v(2.0e4), c=v(2.0)), ot.Shaft(2, 3, L=300.0, odl=v(50.0)),
              ot.Shaft(3, 4, k=v(5.0e4), I=v(0.002), c=v(3.0)),
              ot.Shaft(5, 6, k=v(8.0e4), c=v(6.0))]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=[g1, g2],
                       elastic_gear_elements=[pinion, wheel])


@pytest.mark.parametrize("seed", [0, 1])
def test_elastic_gear_and_dampers_match_opentorsion(seed):
    asm = elastic_chain(seed)
    desc = from_assembly(asm)
    mesh = desc["gears"][-1]
    assert mesh["stiffness"] == asm.elastic_gear_elements[1].k
    assert [m["stiffness"] for m in desc["mounts"]] == [0.0, 0.0, 0.0]
    assert_same_poles(poles(free(desc)), asm)
    assert_same_poles(poles(free(from_assembly(to_assembly(desc)))), asm)


def test_elastic_mesh_is_opentorsions_stiffness_matrix():
    # no rigid mesh: the coordinates are openTorsion's nodes, up to the mesh's reversal,
    # so K, C and M are openTorsion's own, element by element
    asm = elastic_chain(2)
    asm = ot.Assembly(asm.shaft_elements[:2], disk_elements=asm.disk_elements[:3],
                      elastic_gear_elements=asm.elastic_gear_elements)
    mech = build_chain(free(from_assembly(asm))).mechanism
    sign = np.array(list(node_directions(asm).values()), dtype=float)
    k, c = mech.spring_matrices()
    for mine, theirs in ((k, asm.K), (c, asm.C), (mech.mass_matrix, asm.M)):
        np.testing.assert_allclose(sign[:, None] * mine * sign, theirs, rtol=1e-13,
                                   atol=1e-13 * np.abs(theirs).max())


def test_stiff_elastic_mesh_tends_to_the_rigid_one():
    # physics: a mesh 1e4 times stiffer than the shafts moves the modes below it to the
    # rigid mesh's, to O(k_shaft/k_mesh)
    rigid = {"disks": {"a": {"inertia": 1.0}, "p": {"inertia": 0.1}, "w": {"inertia": 0.4},
                       "b": {"inertia": 2.0}},
             "shafts": [{"name": "s1", "between": ["a", "p"], "stiffness": 1.0e4},
                        {"name": "s2", "between": ["w", "b"], "stiffness": 3.0e4}],
             "gears": [{"name": "m", "parent": "p", "child": "w", "teeth": [20, 60]}],
             "motors": [{"name": "drive", "node": "a"}]}
    elastic = {**rigid, "gears": [{**rigid["gears"][0], "stiffness": 1.0e8}]}
    f_rigid = build_chain(rigid).mechanism.undamped_frequencies()
    f_elastic = build_chain(elastic).mechanism.undamped_frequencies()
    assert f_elastic.size == f_rigid.size + 1
    np.testing.assert_allclose(f_elastic[:-1], f_rigid, rtol=1e-3)
    assert np.all(np.abs(f_elastic[:-1] / f_rigid - 1) > 1e-7)   # elastic: lower, not equal


def damped_line(speed_loop: bool, dampers: bool) -> dict:
    desc = {"disks": {"motor": {"inertia": 0.4}, "hub": {"inertia": 0.05},
                      "load": {"inertia": 1.5}},
            "shafts": [{"name": "s1", "between": ["motor", "hub"], "stiffness": 2.0e4,
                        "damping": 1.0},
                       {"name": "s2", "between": ["hub", "load"], "stiffness": 6.0e3,
                        "damping": 0.5}],
            "mounts": [{"name": "bearing", "node": "load", "stiffness": 0.0,
                        "damping": 0.8}] if dampers else [],
            "sensors": [{"name": "speed_motor", "speed": "motor"}],
            "motors": [{"name": "drive", "node": "motor", "controller": {
                "type": "speed", "sensor": "speed_motor", "kp": 5.0, "ki": 50.0}}
                if speed_loop else {"name": "drive", "node": "motor"}]}
    return desc


@pytest.mark.parametrize("speed_loop", [False, True])
def test_chain_held_by_dampers_is_stable(speed_loop):
    desc = damped_line(speed_loop, dampers=True)
    chain = build_chain(desc)
    # the damper stores no energy: the line still turns as one (one rigid-body mode)
    assert chain.mechanism.rigid_modes().shape[1] == 1
    check_stability({"drivetrain": desc})
    # by numpy: one pole at 0 (the angle; with the loop, angle plus integrator), the
    # rest in the open left half-plane
    ev = np.linalg.eigvals(close_loops(chain_plant(chain), chain.motors).A)
    at_zero = np.abs(ev) < 1e-9 * np.abs(ev).max()
    assert at_zero.sum() == 1 and np.all(ev[~at_zero].real < 0)


def test_free_chain_without_damper_or_loop_is_refused():
    # a torque-commanded free line: its rigid body drifts (a double pole at 0)
    with pytest.raises(UnstableGain, match="drifts"):
        check_stability({"drivetrain": damped_line(speed_loop=False, dampers=False)})


def test_damper_entries_checked():
    desc = damped_line(False, True)
    bad = {**desc, "mounts": [{"name": "bearing", "node": "load", "stiffness": 0.0,
                               "damping_ratio": 0.1}]}
    with pytest.raises(ConfigError) as err:
        build_chain(bad)
    assert err.value.field == "drivetrain.mounts[0].damping"
    shaft = {**desc, "shafts": [{**desc["shafts"][0], "stiffness": 0.0}, desc["shafts"][1]]}
    with pytest.raises(ConfigError) as err:
        build_chain(shaft)
    assert err.value.field == "drivetrain.shafts[0].stiffness"


def test_torque_sensor_on_an_elastic_mesh():
    # the mesh torque on the parent, k·δ + c·δ̇, per motor torque: against openTorsion's
    # own M, C, K, gear transformation T and ElasticGear (k + jωc)·(θ_p + ρ·θ_c), by numpy
    asm = elastic_chain(3)
    desc = from_assembly(asm)
    mesh = next(g for g in desc["gears"] if "stiffness" in g)
    plant = mechanism_ss(build_chain(free(desc)).mechanism, {"drive": ("n0", 1.0)}, {},
                         {}, {"mesh": (mesh["name"], 1.0)})
    wheel = asm.elastic_gear_elements[1]
    rho = wheel.R / wheel.parent.R
    t = asm.T(asm.E())
    f = np.geomspace(1.0, 2000.0, 40)
    want = []
    for w in 2 * np.pi * f:
        theta = t @ np.linalg.solve(-w**2 * asm.M + 1j * w * asm.C + asm.K, t[0])
        want.append((wheel.k + 1j * w * wheel.c)
                    * (theta[wheel.parent.node] + rho * theta[wheel.node]))
    sign = node_directions(asm)
    want = sign["n0"] * sign[mesh["parent"]] * np.array(want)
    got = frf(plant, f)[:, 0, 0]
    np.testing.assert_allclose(got, want, rtol=1e-9)
