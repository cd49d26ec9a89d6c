"""openTorsion models as their authors publish them, and gbpipe's export back.

A Python model file importing a helper beside it, run as a script; openTorsion's TORS
JSON read by openTorsion's own parser; the export (``python -m gbpipe
export-opentorsion``) reopened in openTorsion, its modes against gbpipe's of the same
chain. The reference is openTorsion: its ``Parser``, its ``M``, ``C``, ``K`` and
``modal_analysis``.
"""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import numpy as np
import opentorsion as ot
import pytest
import yaml

from gbpipe.__main__ import main
from gbpipe.config import merge, read_yaml
from gbpipe.errors import ConfigError
from gbpipe.fit.keypath import overlay, with_values
from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_files import load_model_file, read_tors, write_tors
from gbpipe.model.opentorsion_io import expand, export, from_assembly, to_assembly
from gbpipe.model.statespace import mechanism_ss

ROOT = Path(__file__).resolve().parents[2]

UTILS = '''
import opentorsion as ot


def coupling(nl, nr, k, c=0.0):
    return ot.Shaft(nl, nr, k=k, c=c)


BEARING_DAMPING = {bearing}
'''

MODEL = '''
import opentorsion as ot
from utils import BEARING_DAMPING, coupling


def test_bench():
    disks = [ot.Disk(0, 0.3, c=BEARING_DAMPING), ot.Disk(1, 0.01),
             ot.Disk(3, 0.02), ot.Disk(4, 0.5, c=BEARING_DAMPING)]
    shafts = [coupling(0, 1, 1.5e4, 0.4), coupling(2, 3, 9.0e3, 0.3),
              ot.Shaft(3, 4, L=250.0, odl=40.0)]
    pinion = ot.Gear(1, 0.004, 18)
    wheel = ot.Gear(2, 0.03, 54, parent=pinion)
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=[pinion, wheel])


def not_an_assembly():
    return [1, 2]


def fails():
    return coupling(0, 1, None)   # no stiffness, no geometry: fails in the helper
'''


def model_dir(root: Path, bearing: float) -> Path:
    """A published model as its authors write it: model.py importing utils.py beside it."""
    root.mkdir()
    (root / "utils.py").write_text(UTILS.format(bearing=bearing))
    (root / "model.py").write_text(MODEL)
    return root


def ot_modes(asm: ot.Assembly) -> np.ndarray:
    """openTorsion's poles ``−ζ·ω_n + j·ω_d`` [rad/s] of the modes (ω_d > 0)."""
    wn, wd, zeta = (np.asarray(x) for x in asm.modal_analysis())
    keep = wd > 1e-7 * wn.max()
    return np.sort_complex(-zeta[keep] * wn[keep] + 1j * wd[keep])


def gb_modes(desc: dict) -> np.ndarray:
    """gbpipe's poles [rad/s] of the modes of a description's chain (ω_d > 0)."""
    ev = np.linalg.eigvals(mechanism_ss(build_chain(desc).mechanism, {}, {}, {}, {}).A)
    return np.sort_complex(ev[ev.imag > 1e-7 * np.abs(ev).max()])


def driven(desc: dict) -> dict:
    return {**desc, "motors": [{"name": "drive", "node": "n0"}]}


def test_model_file_with_a_sibling_import(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model_dir(tmp_path / "bench_a", 0.003)
    model_dir(tmp_path / "bench_b", 0.5)
    # another package's `utils`, imported before: it must not shadow the model's own
    foreign = types.ModuleType("utils")
    monkeypatch.setitem(sys.modules, "utils", foreign)
    path_before, cwd = list(sys.path), Path.cwd()
    out = expand({"opentorsion": "bench_a/model.py:test_bench"})
    assert sys.path == path_before and Path.cwd() == cwd and sys.modules["utils"] is foreign
    assert [m["damping"] for m in out["mounts"]] == [0.003, 0.003]
    # another model's utils is its own (the first one's was not kept)
    other = expand({"opentorsion": "bench_b/model.py:test_bench"})
    assert [m["damping"] for m in other["mounts"]] == [0.5, 0.5]
    # the same model.py, another helper: another provenance (the rules rerun)
    assert other["opentorsion"]["sha256"] != out["opentorsion"]["sha256"]
    # the chain is openTorsion's: modes against its modal_analysis
    sys.path.insert(0, str(tmp_path / "bench_a"))
    sys.modules.pop("utils")
    try:
        import model as published  # as its users run it
        asm = published.test_bench()
    finally:
        sys.path.remove(str(tmp_path / "bench_a"))
        for name in ("model", "utils"):
            sys.modules.pop(name, None)
    np.testing.assert_allclose(gb_modes(driven(out)), ot_modes(asm), rtol=1e-9)


def test_model_file_errors_name_file_and_line(tmp_path):
    root = model_dir(tmp_path / "m", 0.01)
    model = root / "model.py"
    with pytest.raises(ConfigError, match="'m/model.py:nothing'.*no function 'nothing'"):
        load_model_file("m/model.py:nothing", tmp_path)
    line = MODEL.splitlines().index("def not_an_assembly():") + 1
    with pytest.raises(ConfigError, match=rf"model.py:{line}: not_an_assembly\(\) returned "
                       "list, not an opentorsion.Assembly"):
        load_model_file("m/model.py:not_an_assembly", tmp_path)
    # the error inside the helper: its file and line
    line = UTILS.splitlines().index("    return ot.Shaft(nl, nr, k=k, c=c)") + 1
    with pytest.raises(ConfigError, match=rf"utils.py:{line}: TypeError"):
        load_model_file("m/model.py:fails", tmp_path)
    model.write_text(MODEL.replace("def fails():", "def fails(:"))
    line = MODEL.splitlines().index("def fails():") + 1
    with pytest.raises(ConfigError, match=rf"model.py:{line}: syntax error") as err:
        load_model_file("m/model.py:test_bench", tmp_path)
    assert err.value.field == "drivetrain.opentorsion"
    assert str(root) not in sys.path


def tors_line(seed: int) -> dict:
    """A description TORS can hold: a line with dampers to ground, stiffness-given and
    heavy (own inertia) shafts, two meshes on one parent gear (a branch)."""
    rng = np.random.default_rng(seed)

    def v(x: float) -> float:
        return float(x * rng.uniform(0.8, 1.2))

    disks = {f"d{i}": {"inertia": v(j)} for i, j in enumerate([0.5, 0.02, 0.01, 0.3, 0.02,
                                                                  0.6, 0.03, 0.9])}
    return {
        "disks": disks,
        "shafts": [{"name": "s0", "between": ["d0", "d1"], "stiffness": v(2e4), "damping": v(1.0)},
                   {"name": "s1", "between": ["d1", "d2"], "stiffness": v(5e4),
                    "inertia": v(0.004)},
                   {"name": "s2", "between": ["d3", "d4"], "stiffness": v(1e4), "damping": v(0.5)},
                   {"name": "s3", "between": ["d4", "d5"], "stiffness": v(3e4), "damping": v(0.2)},
                   {"name": "s4", "between": ["d6", "d7"], "stiffness": v(8e3), "damping": v(0.3)}],
        "mounts": [{"name": "b0", "node": "d0", "stiffness": 0.0, "damping": v(0.05)},
                   {"name": "b5", "node": "d5", "stiffness": 0.0, "damping": v(0.1)}],
        "gears": [{"name": "g1", "parent": "d2", "child": "d3", "teeth": [17, 61]},
                  {"name": "g2", "parent": "d2", "child": "d6", "ratio": v(0.4)}],
        "motors": [{"name": "drive", "node": "d0"}],
    }


@pytest.mark.parametrize("seed", [0, 1])
def test_tors_round_trip(tmp_path, seed):
    desc = tors_line(seed)
    asm = to_assembly(desc)
    path = tmp_path / "line.json"
    write_tors(asm, path)
    # openTorsion's own reader opens it: the same matrices
    back, _ = ot.Parser.from_tors(json.loads(path.read_text()))
    for got, want in ((back.M, asm.M), (back.C, asm.C), (back.K, asm.K)):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * np.abs(want).max())
    # and gbpipe's config hook (no code run): the same modes as openTorsion's and gbpipe's
    section = expand({"opentorsion": "line.json"}, tmp_path)
    assert section["opentorsion"]["source"] == "line.json"
    np.testing.assert_allclose(gb_modes(driven(section)), ot_modes(asm), rtol=1e-9)
    np.testing.assert_allclose(gb_modes(desc), ot_modes(asm), rtol=1e-9)


def test_tors_as_the_editor_writes_it(tmp_path):
    # two components joined by the structure, a gear pair inside one, a damped disk
    tors = {"name": "pump", "structure": [["motor.shaft", "gearbox.pinion"]], "components": [
        {"name": "motor", "elements": [
            {"name": "rotor", "type": "Disk", "inertia": 0.4, "damping": 0.02},
            {"name": "shaft", "type": "ShaftDiscrete", "stiffness": 3.0e4, "damping": 1.0}]},
        {"name": "gearbox", "elements": [
            {"name": "pinion", "type": "GearElement", "inertia": 0.01, "teeth": 19},
            {"name": "wheel", "type": "GearElement", "inertia": 0.2, "teeth": 77,
             "parent": "pinion"},
            {"name": "out", "type": "ShaftContinuous", "length": 400.0,
             "outerDiameter": 45.0, "innerDiameter": 20.0, "density": 7850},
            {"name": "impeller", "type": "Disk", "inertia": 1.1, "damping": 0.3}]}]}
    (tmp_path / "pump.json").write_text(json.dumps(tors))
    asm, _ = read_tors("pump.json", tmp_path)
    desc = driven(from_assembly(asm))
    assert desc["gears"][0]["ratio"] == 19 / 77
    np.testing.assert_allclose(gb_modes(desc), ot_modes(asm), rtol=1e-9)


def test_tors_errors(tmp_path):
    (tmp_path / "bad.json").write_text('{"components": [\n  {"name": x}]}')
    with pytest.raises(ConfigError, match=r"bad.json:2: not JSON"):
        read_tors("bad.json", tmp_path)
    (tmp_path / "odd.json").write_text('{"components": []}')
    with pytest.raises(ConfigError, match="not a TORS model"):
        read_tors("odd.json", tmp_path)
    # what TORS cannot hold is refused by name, never dropped
    desc = tors_line(0)
    held = {**desc, "mounts": [{"name": "arm", "node": "d0", "stiffness": 500.0}]}
    with pytest.raises(ConfigError, match="spring to ground.*out.py"):
        export(held, tmp_path / "x.json")
    elastic = {**desc, "gears": [{**desc["gears"][0], "stiffness": 1e7}, desc["gears"][1]]}
    with pytest.raises(ConfigError, match="elastic gear mesh"):
        export(elastic, tmp_path / "x.json")
    with pytest.raises(ConfigError, match=r"\.json \(TORS\) or \.py"):
        export(desc, tmp_path / "x.yaml")


def campaign_config(tmp_path: Path) -> Path:
    """A complete config of a described drivetrain (dampers to ground, a speed and a
    torque loop), written as a user writes it."""
    desc = tors_line(3)
    desc["motors"] = [
        {"name": "load", "node": "d7", "sign": -1, "ripple": 1.0, "controller": {
            "type": "torque", "sensor": "torque_out", "kp": 0.1, "ki": 1.0}},
        {"name": "drive", "node": "d0", "ripple": 1.0, "controller": {
            "type": "speed", "sensor": "speed_drive", "kp": 2.0, "ki": 10.0}}]
    desc["sensors"] = [{"name": "speed_load", "speed": "d7"},
                       {"name": "speed_drive", "speed": "d0"},
                       {"name": "torque_out", "torque": "s4"}]
    cfg = merge(read_yaml(ROOT / "config" / "config.yaml"), {
        "drivetrain": desc, "fit": {"records": []},
        "identify": {"versions": ["clean", "raw"],
                     "pairings": [{"name": "Td_to_wl", "inputs": ["motor_torque_drive"],
                                   "outputs": ["speed_load"]}],
                     "best": {"pairing": "Td_to_wl", "version": "raw"}}})
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return path


@pytest.mark.parametrize("suffix", [".json", ".py"])
def test_export_reopens_in_opentorsion(tmp_path, suffix):
    base = campaign_config(tmp_path)
    cfg = read_yaml(base)
    # a fit's overlay (results/fit/<record>.yaml): a shaft's stiffness and a damper
    fitted = with_values(cfg, {"drivetrain.shafts[2].stiffness": 4321.0,
                               "drivetrain.mounts[1].damping": 0.25})
    over = tmp_path / "fit.yaml"
    over.write_text(yaml.safe_dump(overlay(fitted, ["drivetrain.shafts[2].stiffness",
                                                    "drivetrain.mounts[1].damping"])))
    out = tmp_path / f"bench{suffix}"
    assert main(["export-opentorsion", str(base), str(over), "-o", str(out)]) == 0
    if suffix == ".json":
        asm, _ = ot.Parser.from_tors(json.loads(out.read_text()))
    else:
        asm, _ = load_model_file(f"{out}:assembly")
    assert asm.shaft_elements[2].k == pytest.approx(4321.0, rel=1e-12)
    assert sorted(d.c for d in asm.disk_elements if d.c) == pytest.approx(
        sorted([0.25, cfg["drivetrain"]["mounts"][0]["damping"]]), rel=1e-12)
    np.testing.assert_allclose(ot_modes(asm), gb_modes(fitted["drivetrain"]), rtol=1e-9)


def test_export_of_every_element_as_python(tmp_path):
    # a spring to ground and an elastic mesh: the Python model file holds them
    desc = tors_line(4)
    desc["mounts"].append({"name": "arm", "node": "d7", "stiffness": 800.0, "damping": 2.0})
    desc["gears"][1] = {**desc["gears"][1], "stiffness": 2.0e6, "damping": 3.0}
    export(desc, tmp_path / "all.py")
    asm, _ = load_model_file("all.py:assembly", tmp_path)
    # the mesh's parent is d2's rigid Gear (of the other mesh): one ElasticGear
    assert [g.k for g in asm.elastic_gear_elements] == [2.0e6]
    assert any(d.k == 800.0 for d in asm.disk_elements)
    np.testing.assert_allclose(ot_modes(asm), gb_modes(desc), rtol=1e-9)


def test_export_without_drivetrain_fails_clearly(tmp_path, capsys):
    assert main(["export-opentorsion", str(ROOT / "config" / "config.yaml"), "-o",
                 str(tmp_path / "x.json")]) == 1
    assert "drivetrain" in capsys.readouterr().err
