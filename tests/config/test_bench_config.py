"""A bench config asks only for what the bench has; a fitted overlay reruns an imported
chain.

A chain imported from openTorsion (a file written here, as a user writes one) with bench
records (``measured:``) validates with nothing of the simulated campaign: motors without
controllers, named like the paper's motors (whose ripple in config/config.yaml must not
stand for them), no ``noise``/``campaign``/``bench`` keys, no data versions. The same
chain simulated still gets each refusal a simulation needs, by its key path. A fit's
overlay of that chain (``gbpipe.fit.keypath.overlay``, what ``results/fit/<record>.yaml``
holds) loads on top of it, and the chain it gives has openTorsion's modes of the changed
assembly.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import opentorsion as ot
import pytest

from gbpipe import model
from gbpipe.config import ConfigError, load
from gbpipe.errors import UnstableGain
from gbpipe.fit.keypath import get_value, overlay, with_values

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "config" / "config.yaml"

#: Stiffnesses [N·m/rad] of the file's shafts (a coupling, a shaft, a coupling, the
#: output shaft beyond the gear pair).
STIFFNESS = (2.0e4, 3.0e5, 1.5e4, 2.5e5)

MODEL_FILE = f'''
import opentorsion as ot

STIFFNESS = {STIFFNESS!r}


def line(stiffness=STIFFNESS):
    """Motor, coupling, flywheel, coupling, a 1:2.5 gear pair, output shaft, load."""
    disks = [ot.Disk(0, 0.3), ot.Disk(1, 0.02), ot.Disk(2, 2.9), ot.Disk(3, 0.02),
             ot.Disk(6, 0.6)]
    pinion = ot.Gear(4, 0.01, 40.0)
    wheel = ot.Gear(5, 0.15, 100.0, parent=pinion)
    k = stiffness
    shafts = [ot.Shaft(0, 1, k=k[0], c=2.0), ot.Shaft(1, 2, k=k[1], c=5.0),
              ot.Shaft(2, 3, k=k[2], c=2.0), ot.Shaft(3, 4, k=3.0e5, c=5.0),
              ot.Shaft(5, 6, k=k[3], c=4.0)]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=[pinion, wheel])
'''

#: The bench: motors on both ends without a controller, named like the paper's.
DRIVETRAIN = {
    "opentorsion": "line.py:line",
    "motors": [{"name": "driver", "node": "n0"}, {"name": "driven", "node": "n6", "sign": -1}],
    "sensors": [{"name": "speed_motor", "speed": "n0"}, {"name": "speed_load", "speed": "n6"},
                {"name": "torque_output", "torque": "shaft4"}],
}
#: Its records (read when the workflow runs; at load only the mapping is checked).
MEASURED = {"ice1": {
    "files": {"daq": {"path": "bench/ice1.csv", "time": "time"}},
    "sample_rate": 2000.0,
    "signals": {name: {"file": "daq", "channel": name, "unit": unit} for name, unit in (
        ("motor_torque_driver", "N*m"), ("speed_motor", "rad/s"), ("speed_load", "rad/s"),
        ("torque_output", "N*m"))}}}
PAIRINGS = [{"name": "Td_to_wl", "inputs": ["motor_torque_driver"], "outputs": ["speed_load"]}]
#: No spectra.signal: without a tacho no spectra against rpm are made of the records.
BENCH = {"drivetrain": DRIVETRAIN, "measured": MEASURED, "identify": {"pairings": PAIRINGS}}


@pytest.fixture
def bench_dir(tmp_path, monkeypatch):
    (tmp_path / "line.py").write_text(MODEL_FILE)
    monkeypatch.chdir(tmp_path)       # the model file is taken from the working directory
    return tmp_path


def test_bench_config_asks_only_for_what_the_bench_has(bench_dir):
    # config/config.yaml underneath, as the workflow merges it: its campaign, noise
    # (ripple of driver and driven with pulsating torque), controllers and versions
    # [clean, raw, tsa, regression] are the paper campaign's
    cfg = load(CONFIG, BENCH)
    assert all("controller" not in m for m in cfg["drivetrain"]["motors"])
    # the records have no tacho: of the listed versions, raw is one a bench record has
    assert cfg["identify"]["versions"] == ["raw"]
    assert cfg["fit"]["version"] == "raw"        # derived from them
    # with a tacho channel: the spectra against rpm
    tacho = copy.deepcopy(BENCH)
    tacho["measured"]["ice1"]["signals"]["tacho"] = {
        "file": "daq", "channel": "tacho", "quantity": "tacho", "pulses_per_rev": 1}
    # (and then the spectra against rpm: spectra.signal names a signal of the record)
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, tacho)
    assert exc.value.field == "spectra.signal"
    tacho["spectra"] = {"signal": "torque_output"}
    # but no tsa: its cycles (tsa.tests) are orders of the paper's gearbox, not this chain's
    assert load(CONFIG, tacho)["identify"]["versions"] == ["raw"]
    # the paper bench's records with their tacho have it (the listed order kept)
    paper = load(CONFIG, ROOT / "config" / "examples" / "measured.yaml",
                 {"identify": {"versions": ["clean", "raw", "tsa", "regression"]}})
    assert paper["identify"]["versions"] == ["raw", "tsa"]
    # a listed version none of the records has is refused, naming the key
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, BENCH, {"identify": {"versions": ["clean", "tsa"]}})
    assert exc.value.field == "identify.versions"
    assert "tacho" in exc.value.problem
    # what the identification itself needs is still asked: past >= future
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, BENCH, {"identify": {"past": 10, "future": 20}})
    assert exc.value.field == "identify.past"


def _simulated(**keys) -> dict:
    """The same chain without records: the simulated campaign's config."""
    dt = copy.deepcopy(DRIVETRAIN)
    for m, more in zip(dt["motors"], keys.get("motors", ({}, {})), strict=True):
        m.update(more)
    return {"drivetrain": dt, "identify": {"pairings": PAIRINGS, "best": {"pairing": "Td_to_wl"},
                                           **keys.get("identify", {})},
            **({"fit": keys["fit"]} if "fit" in keys else {})}


SPEED = {"type": "speed", "sensor": "speed_motor", "kp": 6.0, "ki": 30.0}
TORQUE = {"type": "torque", "sensor": "torque_output", "kp": 0.2, "ki": 5.0}


def test_the_same_chain_simulated_gets_every_refusal_it_needs(bench_dir):
    # no controllers: the campaign's speed and torque profiles have no motor to follow
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, _simulated())
    assert exc.value.field == "drivetrain.motors"
    assert "speed controller" in exc.value.problem
    only_speed = _simulated(motors=({"controller": SPEED}, {}))
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, only_speed)
    assert exc.value.field == "drivetrain.motors"
    assert "torque controller" in exc.value.problem
    # controllers, no ripple: config.yaml's noise.motor_ripple.driver / .driven (the
    # paper's, with pulsating torque) do not stand for the chain's driver and driven
    loops = ({"controller": SPEED}, {"controller": TORQUE})
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, _simulated(motors=loops))
    assert exc.value.field == "drivetrain.motors[0].ripple"
    rippled = tuple({**m, "ripple": 1.0} for m in loops)
    # config.yaml's versions: TSA and regression are the paper gearbox's
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, _simulated(motors=rippled))
    assert exc.value.field == "identify.versions"
    assert "'tsa'" in exc.value.problem and "'regression'" in exc.value.problem
    versions = {"versions": ["clean", "raw"]}
    # config.yaml's fit of its designed test frees the paper gearbox's stiffness
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, _simulated(motors=rippled, identify=versions))
    assert exc.value.field == "fit.free[0]"
    no_fit = {"records": []}
    cfg = load(CONFIG, _simulated(motors=rippled, identify=versions, fit=no_fit))
    assert [m["ripple"] for m in cfg["drivetrain"]["motors"]] == [1.0, 1.0]
    # a pairing's reference and the stabilization order are the bench records'
    for key, value in (("order", "stabilization"),
                       ("pairings", [{**PAIRINGS[0], "reference": ["motor_torque_driver"]}])):
        with pytest.raises(ConfigError) as exc:
            load(CONFIG, _simulated(motors=rippled, identify={**versions, key: value},
                                    fit=no_fit))
        assert exc.value.field.startswith(f"identify.{key}")
    # the simulated loop must be stable: an integral gain on the output torque far too
    # high is named
    hot = ({**rippled[0]}, {**rippled[1], "controller": {**TORQUE, "ki": 5.0e4}})
    with pytest.raises(UnstableGain) as exc:
        load(CONFIG, _simulated(motors=hot, identify=versions, fit=no_fit))
    assert exc.value.field.startswith("drivetrain.motors[1].controller.k")
    # the same hot gain on the bench's description is no simulation's: not refused
    bench = copy.deepcopy(BENCH)
    bench["drivetrain"]["motors"] = [{**m, **h} for m, h in zip(
        bench["drivetrain"]["motors"], hot, strict=True)]
    load(CONFIG, bench)


def _undamped_hz(asm: ot.Assembly) -> np.ndarray:
    """openTorsion's undamped natural frequencies [Hz] of an assembly (no rigid mode)."""
    wn, wd, _ = (np.asarray(a) for a in asm.modal_analysis(C=np.zeros_like(asm.M)))
    return np.sort(wn[wd > 0]) / (2 * np.pi)


def test_a_fitted_overlay_reruns_an_imported_chain(bench_dir):
    cfg = load(CONFIG, BENCH)
    path = "drivetrain.shafts[2].stiffness"           # the coupling before the gears
    assert get_value(cfg, path) == STIFFNESS[2]
    fitted = overlay(with_values(cfg, {path: 0.8 * STIFFNESS[2]}), [path])
    assert set(fitted["drivetrain"]) == {"shafts"}    # the whole list, as the fit writes it
    rerun = load(CONFIG, BENCH, fitted)
    assert get_value(rerun, path) == 0.8 * STIFFNESS[2]
    assert rerun["drivetrain"]["opentorsion"]["source"] == "line.py:line"
    # its modes are openTorsion's of the assembly built with the changed stiffness
    namespace: dict = {}
    exec(MODEL_FILE, namespace)
    changed = namespace["line"]((*STIFFNESS[:2], 0.8 * STIFFNESS[2], STIFFNESS[3]))
    want = _undamped_hz(changed)
    got = model.bench_chain(rerun).mechanism.undamped_frequencies()
    np.testing.assert_allclose(got, want, rtol=1e-9)
    # and not those of the file's own assembly (the overlay did change the chain)
    assert np.max(np.abs(want / _undamped_hz(namespace["line"]()) - 1)) > 0.01
    # a disk's inertia by name, beside the file, also applies
    heavier = load(CONFIG, BENCH, {"drivetrain": {"disks": {"n2": {"inertia": 3.5}}}})
    assert heavier["drivetrain"]["disks"]["n2"]["inertia"] == 3.5
    assert heavier["drivetrain"]["disks"]["n0"]["inertia"] == 0.3


@pytest.mark.parametrize(("given", "field"), [
    # a list of other elements beside the file: what it defines is not rewritten here
    ({"shafts": [{"name": "s", "between": ["n0", "n1"], "stiffness": 1.0e4}]},
     "drivetrain.shafts"),
    ({"shafts": "whole"}, "drivetrain.shafts"),
    ({"disks": {"flywheel": {"inertia": 1.0}}}, "drivetrain.disks.flywheel"),
    ({"disks": {"n2": 3.5}}, "drivetrain.disks.n2"),
])
def test_elements_beside_the_file_refused_by_key_path(bench_dir, given, field):
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, BENCH, {"drivetrain": given})
    assert exc.value.field == field


def test_an_element_moved_beside_the_file_is_refused(bench_dir):
    cfg = load(CONFIG, BENCH)
    shafts = copy.deepcopy(cfg["drivetrain"]["shafts"])
    shafts[1]["between"] = ["n1", "n3"]
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, BENCH, {"drivetrain": {"shafts": shafts}})
    assert exc.value.field == "drivetrain.shafts[1].between"
