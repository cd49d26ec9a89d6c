"""Configuration validation: every bad input stops with an error naming the field."""

from __future__ import annotations

import copy

import pytest
import yaml

from gbpipe.config import ConfigError, load, merge, validate
from gbpipe.model import InstabilityError

from .conftest import CI_CONFIG, CONFIG, EXAMPLE


def _raw():
    with open(CONFIG) as fh:
        return yaml.safe_load(fh)


def test_default_and_ci_configs_load():
    full = load(CONFIG)
    ci = load(CONFIG, CI_CONFIG)
    assert full["gearbox"] == ci["gearbox"]
    assert isinstance(full["gearbox"]["stiffness"][0], float)   # 1.5e8 read as a number


def test_example_gearbox_replaces_lists():
    cfg = load(CONFIG, EXAMPLE)
    assert [s["type"] for s in cfg["gearbox"]["stages"]] == ["planetary", "parallel", "parallel"]


def _set(cfg, path, value):
    node = cfg
    for key in path[:-1]:
        node = node[key]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return cfg


_DELETE = object()


@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        (("gearbox", "inertia", 0), -1.0, r"gearbox\.inertia\[0\]"),
        (("gearbox", "inertia", 2), 0.0, r"gearbox\.inertia\[2\]"),
        (("bench", "motor_inertia", "driver"), 0, r"bench\.motor_inertia\.driver"),
        (("gearbox", "stages", 0, "ring"), 20, r"gearbox\.stages\[0\]\.ring"),
        (("gearbox", "stages", 1, "sun"), 21.5, r"gearbox\.stages\[1\]\.sun"),
        (("gearbox", "stages", 2, "pinion"), _DELETE, r"gearbox\.stages\[2\]\.pinion"),
        (("bench", "coupling", "stiffness"), _DELETE, r"bench\.coupling\.stiffness"),
        (("gearbox", "inertia", 0), "6730 kg m2", r"gearbox\.inertia\[0\]"),
        (("bench", "lss_shaft", "stiffness"), "3e8 Nm/rad", r"bench\.lss_shaft\.stiffness"),
        (("gearbox", "stiffness"), [1.5e8, 1.5e7], r"gearbox\.stiffness"),
        (("gearbox", "damping_ratio", "shaft"), 1.5, r"gearbox\.damping_ratio\.shaft"),
        (("gearbox", "housing", "mount"), "rubber", r"gearbox\.housing\.mount"),
    ],
)
def test_bad_config_names_the_field(path, value, field):
    cfg = _set(copy.deepcopy(_raw()), path, value)
    with pytest.raises(ConfigError, match=field):
        validate(cfg)


def test_missing_section():
    cfg = _raw()
    del cfg["bench"]
    with pytest.raises(ConfigError, match="'bench' is missing"):
        validate(cfg)


@pytest.mark.parametrize(
    ("over", "field"),
    [
        ({"bench": {"torque_controller": {"ki": 500.0}}}, "bench.torque_controller.ki"),
        ({"bench": {"torque_controller": {"ki": 50.0}}}, "bench.torque_controller.ki"),
    ],
)
def test_unstable_gains_are_refused_by_name(over, field):
    with pytest.raises(InstabilityError, match=field.replace(".", r"\.")) as exc:
        validate(merge(_raw(), over))
    assert isinstance(exc.value, ConfigError)


def test_stable_gains_accepted():
    validate(merge(_raw(), {"bench": {"torque_controller": {"kp": 1.0, "ki": 0.5}}}))


def test_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        load(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("gearbox: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load(bad)
