"""Loading, defaults and derived defaults of the configuration (the refusals are in
test_bad_configs.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from gbpipe import model
from gbpipe.config import Config, ConfigError, load, merge, order_bound, schema, validate
from gbpipe.errors import UnstableGain

ROOT = Path(__file__).resolve().parents[2]
CONFIG, CI_CONFIG = ROOT / "config" / "config.yaml", ROOT / "config" / "ci.yaml"
EXAMPLES = sorted((ROOT / "config" / "examples").glob("*.yaml"))


def _raw(path=CONFIG):
    with open(path) as fh:
        return yaml.safe_load(fh)


@pytest.mark.parametrize("overlays", [(), (CI_CONFIG,), *[(e,) for e in EXAMPLES]],
                         ids=["config", "ci", *[e.stem for e in EXAMPLES]])
def test_shipped_configs_load(overlays):
    cfg = load(CONFIG, *overlays)
    assert isinstance(cfg, Config)
    assert isinstance(cfg["gearbox"]["stiffness"][0], float)   # 1.5e8 read as a number


def _minimal():
    """config.yaml reduced to the keys the schema requires (no defaults written)."""
    full = _raw()
    req = schema()["required"]
    cfg = {k: full[k] for k in req}
    cfg["gearbox"] = {k: full["gearbox"][k] for k in
                      ("stages", "inertia", "stiffness", "damping_ratio", "housing")}
    sc, tc = full["bench"]["speed_controller"], full["bench"]["torque_controller"]
    cfg["bench"] = {**full["bench"], "speed_controller": {"kp": sc["kp"], "ki": sc["ki"]},
                    "torque_controller": {"kp": tc["kp"], "ki": tc["ki"]}}
    del cfg["bench"]["torque_limit"]
    cfg["noise"] = {"sensor": full["noise"]["sensor"],
                    "motor_ripple": {m: {"broadband": r["broadband"]}
                                     for m, r in full["noise"]["motor_ripple"].items()}}
    cfg["campaign"] = {k: full["campaign"][k] for k in
                       ("nominal", "step", "full_range", "settle", "hold", "sample_rate")}
    cfg["excitation"] = {"load_reference": 16250.0}
    cfg["sweep"] = {k: full["sweep"][k] for k in
                    ("rpm_start", "rpm_end", "duration", "torque", "sample_rate")}
    cfg["tsa"] = {"variants": full["tsa"]["variants"]}
    cfg["identify"] = {"pairings": full["identify"]["pairings"]}
    return cfg


def _defaults(sub, path=()):
    """Every (key path, default) declared in a schema node (following $ref)."""
    root = schema()
    if "$ref" in sub:
        sub = {**root["$defs"][sub["$ref"].split("/")[-1]], **sub}
    for name, prop in sub.get("properties", {}).items():
        if "default" in prop:
            yield (*path, name), prop["default"]
        yield from _defaults(prop, (*path, name))


def test_minimal_config_gets_every_schema_default():
    cfg = validate(_minimal())
    checked = 0
    for path, default in _defaults(schema()):
        node = cfg
        for key in path[:-1]:
            node = node[key]
        if path[0] == "sweep" and path[1] == "noise":
            continue   # derived from the top-level noise (next test)
        if path == ("identify", "order"):
            continue   # "model" is resolved to a number of states (next tests)
        if isinstance(default, dict):
            assert isinstance(node[path[-1]], dict)
        else:
            assert node[path[-1]] == default, path
        checked += 1
    assert checked >= 40
    assert isinstance(cfg["identify"]["order"], int)
    assert cfg["bench"]["speed_controller"]["setpoint_weight"] == 1.0


def _oscillatory_hz(A: np.ndarray) -> np.ndarray:
    """|s|/2π [Hz] of each conjugate pair of eigenvalues of A (numpy, not gbpipe.lti)."""
    ev = np.linalg.eigvals(A)
    scale = np.abs(ev).max()
    # a free rotor's double pole at 0 may split into a tiny pair: not a mode
    return np.abs(ev[(ev.imag > 1e-9 * scale) & (np.abs(ev) > 1e-6 * scale)]) / (2 * np.pi)


def test_order_model_follows_the_gearbox():
    # "model" = states of the open-loop bench in the identified band: each degree of
    # freedom is two states; a mode above identify.frf.f_max drops out of the band
    for overlays in ((), (ROOT / "config" / "examples" / "gearbox_1planetary_2parallel.yaml",)):
        cfg = load(ROOT / "config" / "config.yaml", *overlays)
        A = model.bench_ss(cfg, closed=False).A
        f_modes = _oscillatory_hz(A)
        above = int(np.sum(f_modes > cfg["identify"]["frf"]["f_max"]))
        assert cfg["identify"]["order"] == A.shape[0] - 2 * above
    paper = load(ROOT / "config" / "config.yaml")
    assert paper["identify"]["order"] == 24   # 12 DOF, all below 350 Hz: the paper's order
    auto = load(ROOT / "config" / "config.yaml", {"identify": {"order": "auto"}})
    assert auto["identify"]["order"] == "auto" and auto["identify"]["max_order"] == 26


def test_derived_defaults():
    raw = _minimal()
    raw["tsa"]["averaging"] = "sliding"
    raw["tsa"]["variants"] = [{"name": "a", "cycles": ["hss"]},
                              {"name": "b", "cycles": ["mesh2"], "averaging": "quadratic"},
                              {"name": "c", "cycles": ["hss", "mesh2"]}]
    loud = {"broadband": 300.0, "pole_pairs": 3, "pulsating": []}
    raw["sweep"]["noise"] = {"motor_ripple": {"driven": loud}}
    cfg = validate(raw)
    assert [v["averaging"] for v in cfg["tsa"]["variants"]] == ["sliding", "quadratic",
                                                                 "sliding"]
    # every level the sweep does not give is the top-level one, motor by motor
    assert cfg["sweep"]["noise"] == {
        "motor_ripple": {"driver": cfg["noise"]["motor_ripple"]["driver"], "driven": loud},
        "sensor": raw["noise"]["sensor"], "encoder": cfg["noise"]["encoder"]}
    assert cfg["identify"]["tests"] == cfg["campaign"]["tests"]
    assert cfg["identify"]["best"] == {"test": "speed_up", "profile": "square",
                                       "pairing": raw["identify"]["pairings"][0]["name"],
                                       "version": "clean"}
    assert cfg["identify"]["max_order"] == order_bound(cfg)


def test_merge_on_a_loaded_config_derives_again():
    cfg = load(CONFIG)
    quad = validate(merge(cfg, {"tsa": {"averaging": "sliding"}}))
    # variants without their own averaging follow the new tsa.averaging; carrier2 keeps its
    # explicit quadratic
    assert [v["averaging"] for v in quad["tsa"]["variants"]] == [
        "sliding", "quadratic", "sliding", "sliding"]
    louder = validate(merge(cfg, {"noise": {"sensor": {"speed": 0.01}}}))
    assert louder["sweep"]["noise"]["sensor"]["speed"] == 0.01
    quieter = validate(merge(cfg, {"noise": {"encoder": {"counts_per_rev": 4096}}}))
    assert quieter["sweep"]["noise"]["encoder"]["counts_per_rev"] == 4096   # derived again
    assert validate(cfg) == cfg


def test_order_bound_counts_the_bench_states_in_band():
    cfg = load(CONFIG)
    A = model.bench_ss(cfg).A
    # 12 rotating bodies (24 states) + the two PI integrators; every mode of the paper's
    # bench is below 350 Hz (its highest is the mesh-stage pair near 339 Hz)
    assert A.shape[0] == 26
    assert order_bound(cfg) == 26 == cfg["identify"]["max_order"]
    low = validate(merge(cfg, {"identify": {"frf": {"f_max": 100.0}}}))
    f_hz = _oscillatory_hz(A)
    n_osc = int(np.sum(f_hz <= 100.0))
    n_real = int(np.sum(np.abs(np.linalg.eigvals(A).imag) < 1e-9))
    assert low["identify"]["max_order"] == 2 * n_osc + n_real < 26


def test_max_order_follows_the_gearbox():
    example = load(CONFIG, ROOT / "config" / "examples" / "gearbox_1planetary_2parallel.yaml")
    assert example["identify"]["max_order"] != load(CONFIG)["identify"]["max_order"]


def test_zero_integral_gain_is_not_unstable():
    load(CONFIG, {"bench": {"speed_controller": {"ki": 0.0}}})
    load(CONFIG, {"bench": {"torque_controller": {"ki": 0.0}}})


def test_unstable_gain_is_named():
    with pytest.raises(UnstableGain) as exc:
        load(CONFIG, CI_CONFIG, {"bench": {"torque_controller": {"ki": 50.0}}})
    assert exc.value.field.startswith("bench.torque_controller.ki")


def test_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        load(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("gearbox: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load(bad)
    bad.write_text("- 1\n")
    with pytest.raises(ConfigError, match="mapping"):
        load(bad)


def test_missing_section_is_named():
    raw = _raw()
    del raw["bench"]
    with pytest.raises(ConfigError) as exc:
        validate(raw)
    assert exc.value.field == "bench"


def _objects(node, path="(top)"):
    """Every object node of the schema (those with properties), with where it is."""
    if isinstance(node, dict):
        if "properties" in node:
            yield path, node
        for key, sub in node.items():
            yield from _objects(sub, f"{path}/{key}")
    elif isinstance(node, list):
        for i, sub in enumerate(node):
            yield from _objects(sub, f"{path}/{i}")


def test_schema_is_closed_everywhere():
    found = list(_objects(schema()))
    assert len(found) >= 30
    # `if` clauses only select a branch; every object a config value must match is closed
    open_ = [p for p, node in found if node.get("additionalProperties") is not False
             and "/if" not in p]
    assert open_ == []


def test_a_modal_table_the_workflow_makes_is_not_refused():
    """``fit.modes.file`` under this run's results folder (``tables/modes_measured.csv``
    of the modes stage) does not exist before the run: accepted at load, while a missing
    table elsewhere is refused (tests/config/bad_configs.py)."""
    for results in ("results", "study/run_a"):
        over = {"results": results, "fit": {"data": "modes", "modes": {
            "file": f"{results}/tables/modes_measured.csv"}}}
        cfg = load(CONFIG, CI_CONFIG, over)
        assert cfg["fit"]["modes"]["file"] == f"{results}/tables/modes_measured.csv"
