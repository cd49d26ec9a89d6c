"""openTorsion assemblies imported into the one mechanics core, and exported back.

The reference is openTorsion itself: its own element matrices (consistent shaft mass,
geometric stiffness), its own gear-constraint reduction ``T`` and its ``modal_analysis``.
The FRFs are computed here with numpy from openTorsion's ``M``, ``C``, ``K`` and ``T``
(``(−ω²M + jωC + K)⁻¹``), gbpipe's from the state space of the built mechanism.
"""

from __future__ import annotations

import hashlib
import sys

import numpy as np
import opentorsion as ot
import pytest

from gbpipe import model
from gbpipe.config import merge, validate
from gbpipe.errors import ConfigError
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.lti import frf
from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_io import (
    expand,
    from_assembly,
    node_directions,
    to_assembly,
)
from gbpipe.model.statespace import mechanism_ss


def shaft_line(seed: int) -> ot.Assembly:
    """A motor, a shaft line with couplings and a flywheel, three gear pairs, a load.

    22 nodes, 3 meshes (19 degrees of freedom); geometric shafts (consistent mass from
    steel) and stiffness-given ones (with and without own inertia); the motor and the
    load held to ground by damped springs (speed and torque loops). Every inertia and
    stiffness varies ±20 % with the seed.
    """
    rng = np.random.default_rng(seed)

    def v(x: float) -> float:
        return float(x * rng.uniform(0.8, 1.2))

    inertia = [0.8, 0.05, 0.04, 0.2, 3.0, 0.2, 0.1, 0.6, 0.05, 0.3, 0.05, 0.08, 1.5,
               0.1, 0.2, 0.1, 4.0, 0.5, 0.2, 0.3, 0.2, 12.0]
    disks = [ot.Disk(n, v(j)) for n, j in enumerate(inertia) if n not in (0, 6, 7, 11, 12,
                                                                        15, 16, 21)]
    disks += [ot.Disk(0, v(0.8), c=v(60.0), k=v(800.0)),
              ot.Disk(21, v(12.0), c=v(900.0), k=v(2.0e4))]
    p1 = ot.Gear(6, v(0.1), 50.0)
    w1 = ot.Gear(7, v(0.6), 150.0, parent=p1)
    p2 = ot.Gear(11, v(0.08), 40.0)
    w2 = ot.Gear(12, v(1.5), 136.0, parent=p2)
    p3 = ot.Gear(15, v(0.1), 30.0)
    w3 = ot.Gear(16, v(4.0), 105.0, parent=p3)
    pairs = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 6), (7, 8), (8, 9), (9, 10),
             (10, 11), (12, 13), (13, 14), (14, 15), (16, 17), (17, 18), (18, 19), (19, 20),
             (20, 21)]
    shafts = []
    for i, (a, b) in enumerate(pairs):
        if i % 3 == 0:    # steel, from its geometry [mm]
            shafts.append(ot.Shaft(a, b, L=v(400.0), odl=v(60.0 + 10 * i), c=v(20.0)))
        elif i % 3 == 1:  # a coupling: stiffness given, own inertia given
            shafts.append(ot.Shaft(a, b, k=v(2.0e5 * (1 + i)), I=v(0.004), c=v(15.0)))
        else:
            shafts.append(ot.Shaft(a, b, k=v(5.0e5 * (1 + i)), c=v(30.0)))
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=[p1, w1, p2, w2, p3, w3])


def built(description: dict):
    """The mechanism of an imported description, through the one chain builder."""
    return build_chain(description).mechanism


def ot_frf(asm: ot.Assembly, f_hz: np.ndarray, node_in: int, node_out: int,
           shaft: ot.Shaft) -> tuple[np.ndarray, np.ndarray]:
    """Speed of ``node_out`` and torque of ``shaft`` per torque on ``node_in``, by numpy
    from openTorsion's reduced M, C, K and its gear transformation."""
    t = asm.T(asm.E()) if asm.gear_elements else np.eye(asm.dofs)
    speed, torque = [], []
    for w in 2 * np.pi * f_hz:
        x = np.linalg.solve(-w**2 * asm.M + 1j * w * asm.C + asm.K, t[node_in])
        theta = t @ x
        speed.append(1j * w * theta[node_out])
        torque.append((shaft.k + 1j * w * shaft.c) * (theta[shaft.nl] - theta[shaft.nr]))
    return np.array(speed), np.array(torque)


@pytest.mark.parametrize("seed", [0, 1])
def test_modes_and_frf_match_opentorsion(seed):
    asm = shaft_line(seed)
    desc = from_assembly(asm)
    assert len(desc["disks"]) == 22 and len(desc["gears"]) == 3
    mech = built(desc)

    # undamped: openTorsion's modal_analysis without damping, |λ| [rad/s] -> Hz
    wn0, wd0, _ = (np.asarray(a) for a in asm.modal_analysis(C=np.zeros_like(asm.M)))
    np.testing.assert_allclose(mech.undamped_frequencies(), np.sort(wn0[wd0 > 0]) / (2 * np.pi),
                               rtol=1e-6)

    # damped: the poles of openTorsion's own state matrix
    wn, wd, zeta = asm.modal_analysis()
    up = np.asarray(wd) > 0
    sign = node_directions(asm)
    load, shaft = 21, asm.shaft_elements[-1]
    sys = mechanism_ss(mech, {"motor": ("n0", 1.0)}, {},
                       {"motor": "n0", "load": f"n{load}"},
                       {"torque": (f"shaft{len(asm.shaft_elements) - 1}", 1.0)})
    poles = np.linalg.eigvals(sys.A)
    poles = np.sort_complex(poles[poles.imag > 0])
    ref = np.sort_complex((-np.asarray(zeta) * np.asarray(wn) + 1j * np.asarray(wd))[up])
    np.testing.assert_allclose(poles, ref, rtol=1e-6)

    f = np.geomspace(0.5, 5000.0, 150)   # every mode (2-3.3 kHz the highest)
    h = frf(sys, f)
    direct = ot_frf(asm, f, 0, 0, shaft)[0]
    np.testing.assert_allclose(h[:, 0, 0], direct, rtol=1e-6)   # the driving point
    speed, torque = ot_frf(asm, f, 0, load, shaft)
    s = sign["n0"] * sign[f"n{load}"]
    # 1e-6 relative, above the round-off floor of float64 solves (1e-13 of the largest
    # response): past the three meshes the response falls to 1e-30 of it at 5 kHz
    for got, want in ((h[:, 1, 0], s * speed), (h[:, 2, 0], s * torque)):
        assert np.all(np.abs(got - want) <= 1e-6 * np.abs(want) + 1e-13 * np.abs(want).max())


def test_round_trip():
    desc = from_assembly(shaft_line(3))
    back = from_assembly(to_assembly(desc))
    assert back.keys() == desc.keys()
    assert back["disks"].keys() == desc["disks"].keys()
    for name, d in desc["disks"].items():
        assert back["disks"][name]["inertia"] == pytest.approx(d["inertia"], rel=1e-15)
    for kind in ("shafts", "mounts", "gears"):
        assert len(back[kind]) == len(desc[kind])
        for a, b in zip(back[kind], desc[kind], strict=True):
            assert a.keys() == b.keys()
            for key, value in b.items():
                if isinstance(value, float):
                    assert a[key] == pytest.approx(value, rel=1e-14), (kind, key)
                else:
                    assert a[key] == value


def test_export_of_a_written_description():
    # teeth and damping ratios, as a person writes them: openTorsion's own modal
    # analysis of the export has the poles of the chain builder's mechanism
    desc = {
        "disks": {"motor": {"inertia": 0.08}, "hub": {"inertia": 0.01},
                  "flywheel": {"inertia": 1.2}, "wheel": {"inertia": 0.3},
                  "pinion": {"inertia": 0.02}, "load": {"inertia": 0.05}},
        "shafts": [
            {"name": "s1", "between": ["motor", "hub"], "stiffness": 1.2e4,
             "damping_ratio": 0.02},
            {"name": "s2", "between": ["hub", "flywheel"], "stiffness": 8.0e3, "damping": 0.5,
             "inertia": 0.006},
            {"name": "s3", "between": ["flywheel", "wheel"], "stiffness": 2.0e4,
             "damping_ratio": 0.03},
            {"name": "s4", "between": ["pinion", "load"], "stiffness": 3.0e3,
             "damping_ratio": 0.02}],
        "mounts": [{"name": "arm", "node": "motor", "stiffness": 300.0, "damping_ratio": 0.3}],
        "gears": [{"name": "g1", "parent": "wheel", "child": "pinion", "teeth": [96, 29]}],
    }
    asm = to_assembly(desc)
    wn, wd, zeta = (np.asarray(a) for a in asm.modal_analysis())
    ref = np.sort_complex((-zeta * wn + 1j * wd)[wd > 0])
    sys = mechanism_ss(built(desc), {}, {}, {}, {})
    poles = np.linalg.eigvals(sys.A)
    np.testing.assert_allclose(np.sort_complex(poles[poles.imag > 0]), ref, rtol=1e-9)
    assert from_assembly(asm)["gears"][0]["ratio"] == pytest.approx(96 / 29, rel=1e-15)
    with pytest.raises(ConfigError) as err:
        to_assembly({**desc, "gears": [{**desc["gears"][0], "housing": "hub"}]})
    assert err.value.field == "drivetrain.gears[0].housing"


def test_shaft_inertia_is_consistent_mass_not_lumped():
    # two disks on one heavy shaft: openTorsion's consistent matrix assembled by hand
    # (a lumped J/2 at each end would give another frequency)
    k, j1, j2, js = 1.0e5, 0.3, 0.5, 0.24
    asm = ot.Assembly([ot.Shaft(0, 1, k=k, I=js / 6)], disk_elements=[ot.Disk(0, j1),
                                                                       ot.Disk(1, j2)])
    desc = from_assembly(asm)
    desc["motors"] = [{"name": "drive", "node": "n0"}]    # a free chain needs a driver
    mech = built(desc)
    m = np.array([[j1 + js / 3, js / 6], [js / 6, j2 + js / 3]])
    kk = k * np.array([[1.0, -1.0], [-1.0, 1.0]])
    w2 = np.linalg.eigvals(np.linalg.solve(m, kk)).real.max()
    np.testing.assert_allclose(mech.undamped_frequencies(), [np.sqrt(w2) / (2 * np.pi)],
                               rtol=1e-12)


def test_soft_mount_mode_is_not_taken_for_rigid():
    # a motor on a soft mount behind a stiff shaft: its mode 1e-5 of the shaft's in
    # frequency; the closed form (product of the two ω² = det K / det M) keeps it
    j1, j2, k_mount, k_shaft = 10.0, 1.0e-3, 10.0, 1.0e7
    asm = ot.Assembly([ot.Shaft(0, 1, k=k_shaft)],
                      disk_elements=[ot.Disk(0, j1, k=k_mount), ot.Disk(1, j2)])
    f = built(from_assembly(asm)).undamped_frequencies()
    trace = (k_mount + k_shaft) / j1 + k_shaft / j2
    high = 0.5 * (trace + np.sqrt(trace**2 - 4 * k_mount * k_shaft / (j1 * j2)))
    low = k_mount * k_shaft / (j1 * j2) / high
    np.testing.assert_allclose(f, np.sqrt([low, high]) / (2 * np.pi), rtol=1e-6)


ASSEMBLY_FILE = '''
import opentorsion as ot


def bench():
    return ot.Assembly([ot.Shaft(0, 1, k=2.0e4, c=3.0), ot.Shaft(2, 3, k=1.0e4, c=2.0)],
                       disk_elements=[ot.Disk(0, 0.5, c=5.0, k=100.0), ot.Disk(3, 1.0)],
                       gear_elements=[g := ot.Gear(1, 0.1, 1.0), ot.Gear(2, 0.2, 2.0, parent=g)])


def free_bench():
    # the line free to turn (no disk spring to ground): what a simulated campaign needs
    return ot.Assembly([ot.Shaft(0, 1, k=2.0e4, c=3.0), ot.Shaft(2, 3, k=1.0e4, c=2.0)],
                       disk_elements=[ot.Disk(0, 0.5), ot.Disk(3, 1.0)],
                       gear_elements=[g := ot.Gear(1, 0.1, 1.0), ot.Gear(2, 0.2, 2.0, parent=g)])


def not_an_assembly():
    return 3


def broken():
    return ot.Assembly([ot.Shaft(0, 1)])
'''


def test_config_hook(tmp_path):
    path = tmp_path / "asm.py"
    path.write_text(ASSEMBLY_FILE)
    section = {"opentorsion": "asm.py:bench",
               "sensors": [{"name": "speed_load", "speed": "n3"}]}
    out = expand(section, tmp_path)
    assert out["sensors"] == section["sensors"]
    assert out["opentorsion"] == {"source": "asm.py:bench",
                                  "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
    assert [s["stiffness"] for s in out["shafts"]] == [2.0e4, 1.0e4]
    assert out["gears"] == [{"name": "gear0", "parent": "n1", "child": "n2", "ratio": 0.5}]
    assert out["mounts"][0] == {"name": "mount0", "node": "n0", "stiffness": 100.0,
                                "damping": 5.0}
    # expanded once: a second pass keeps a fitted value
    out["shafts"][1]["stiffness"] = 7.0e3
    assert expand(out, tmp_path)["shafts"][1]["stiffness"] == 7.0e3


def test_config_section_from_a_file(cfg, tmp_path, monkeypatch):
    path = tmp_path / "asm.py"
    path.write_text(ASSEMBLY_FILE)
    monkeypatch.chdir(tmp_path)           # a relative file is read from the working dir
    # a load motor on n3 (torque loop) and a drive motor on n0 (speed loop): what the
    # simulated campaign of a config with this drivetrain needs
    section = {"opentorsion": "asm.py:free_bench",
               "motors": [{"name": "load", "node": "n3", "sign": -1, "ripple": 1.0,
                           "controller": {
                   "type": "torque", "sensor": "torque_out", "kp": 0.1, "ki": 1.0,
                   "feedforward": 1.0}},
                   {"name": "drive", "node": "n0", "ripple": 1.0, "controller": {
                       "type": "speed", "sensor": "speed_drive", "kp": 2.0, "ki": 10.0,
                       "setpoint_weight": 0.5}}],
               "sensors": [{"name": "speed_load", "speed": "n3"},
                           {"name": "speed_drive", "speed": "n0"},
                           {"name": "torque_out", "torque": "shaft1"}]}
    campaign = {"fit": {"records": []},
                "identify": {"versions": ["clean", "raw"],
                             "pairings": [{"name": "Td_to_wl", "inputs": ["motor_torque_drive"],
                                           "outputs": ["speed_load"]}],
                             "best": {"pairing": "Td_to_wl", "version": "raw"}}}
    custom = validate(merge(cfg, {"drivetrain": section, **campaign}))
    # the file's other assembly grounds the drive disk (Disk k): no steady rotation to
    # start a simulated record from, refused at load with the element
    with pytest.raises(ConfigError, match=r"drivetrain\.mounts.*0 rigid-body modes"):
        validate(merge(cfg, {"drivetrain": {**section, "opentorsion": "asm.py:bench"},
                             **campaign}))
    dt = custom["drivetrain"]
    assert dt["opentorsion"] == {"source": "asm.py:free_bench",
                                 "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
    # the plant of the built chain against the file's assembly, by numpy: the speed of
    # node 3 per torque on it (nodes 2 and 3 lie beyond one mesh: the same direction)
    asm = to_assembly(dt)
    ss = model.bench_ss(custom, closed=False)
    f = np.array([3.0, 30.0, 300.0])
    t = asm.T(asm.E())
    want = [1j * w * (t @ np.linalg.solve(-w**2 * asm.M + 1j * w * asm.C + asm.K, t[3]))[3]
            for w in 2 * np.pi * f]
    # the load motor brakes (sign -1): its torque input acts on n3 negatively
    got = frf(ss, f)[:, ss.outputs.index("speed_load"), ss.inputs.index("motor_torque_load")]
    np.testing.assert_allclose(-got, want, rtol=1e-9)
    # a fit's key path on the expanded section survives validation (nothing read again)
    path.write_text("raise RuntimeError('read twice')")
    fitted = validate(with_values(custom, {"drivetrain.shafts[1].stiffness": 7.5e3}))
    assert get_value(fitted, "drivetrain.shafts[1].stiffness") == 7.5e3


@pytest.mark.parametrize("spec, words", [
    ("missing.py:bench", "does not exist"),
    ("asm.py:nothing", "no function 'nothing'"),
    ("asm.py:not_an_assembly", "not an opentorsion.Assembly"),
    ("asm.py", "path/to/file.py:function"),
    ("asm.py:broken", r"broken\(\) failed at .*asm.py:\d+: TypeError"),
])
def test_config_hook_errors(tmp_path, spec, words):
    (tmp_path / "asm.py").write_text(ASSEMBLY_FILE)
    with pytest.raises(ConfigError, match=words) as err:
        expand({"opentorsion": spec}, tmp_path)
    assert err.value.field == "drivetrain.opentorsion"


def test_config_hook_refuses_both(tmp_path):
    (tmp_path / "asm.py").write_text(ASSEMBLY_FILE)
    with pytest.raises(ConfigError) as err:
        expand({"opentorsion": "asm.py:bench", "shafts": []}, tmp_path)
    assert err.value.field == "drivetrain.shafts"


def test_missing_opentorsion_names_the_extra(tmp_path, monkeypatch):
    (tmp_path / "asm.py").write_text(ASSEMBLY_FILE)
    monkeypatch.setitem(sys.modules, "opentorsion", None)   # import fails
    with pytest.raises(ConfigError, match=r"pip install gbpipe\[opentorsion\]"):
        expand({"opentorsion": "asm.py:bench"}, tmp_path)


def test_refused_loop():
    # a shaft that closes a loop around a mesh: the reversal matters
    disks = [ot.Disk(0, 1.0), ot.Disk(1, 1.0)]
    g = ot.Gear(0, 0.1, 1.0)
    loop = ot.Assembly([ot.Shaft(0, 1, k=1e4)], disk_elements=disks,
                       gear_elements=[g, ot.Gear(1, 0.1, 2.0, parent=g)])
    with pytest.raises(ConfigError, match="loop"):
        from_assembly(loop)
