"""Key paths of the fit through mappings of named entries (a general drivetrain's
``drivetrain.disks.load.inertia``) as well as indexed lists."""

from __future__ import annotations

import copy

import pytest

from gbpipe.fit.keypath import get_value, overlay, with_values
from gbpipe.fit.report import parameter_unit
from tests.pint_units import udunits_quantity as q


def test_named_and_indexed_entries_are_read_written_and_overlaid():
    cfg = {"drivetrain": {"disks": {"load": {"inertia": 5.0}, "motor": {"inertia": 2.0}},
                          "shafts": [{"stiffness": 1e6}, {"stiffness": 2e6}]}}
    before = copy.deepcopy(cfg)
    paths = ["drivetrain.disks.load.inertia", "drivetrain.shafts[1].stiffness"]
    assert [get_value(cfg, p) for p in paths] == [5.0, 2e6]
    new = with_values(cfg, dict(zip(paths, [7.0, 3e6], strict=True)))
    assert [get_value(new, p) for p in paths] == [7.0, 3e6]
    assert cfg == before                                   # the prior is not touched
    assert overlay(new, paths) == {"drivetrain": {"disks": {"load": {"inertia": 7.0}},
                                                  "shafts": [{"stiffness": 1e6},
                                                             {"stiffness": 3e6}]}}
    assert [parameter_unit(p) for p in paths] == ["kg m2", "N m rad-1"]


def test_every_parameter_unit_makes_its_torque_term_a_torque():
    """Each free parameter's unit times the quantity it multiplies in the equations of
    motion (docs/drivetrain.md) is a torque [N·m], checked with pint; a drivetrain
    controller gain takes its controller's type."""
    motors = [{"controller": {"type": "torque"}}, {"controller": {"type": "speed"}}]
    cfg = {"drivetrain": {"motors": motors}}
    cases = {  # path -> what it multiplies
        "drivetrain.disks.load.inertia": "rad s-2",
        "drivetrain.shafts[2].stiffness": "rad",
        "drivetrain.shafts[2].damping": "rad s-1",
        "drivetrain.mounts[0].damping": "rad s-1",
        "bench.speed_controller.kp": "rad s-1",
        "bench.speed_controller.ki": "rad",             # integral of the speed error
        "drivetrain.motors[1].controller.kp": "rad s-1",
        "drivetrain.motors[1].controller.ki": "rad",
        "bench.torque_controller.kp": "N m",
        "drivetrain.motors[0].controller.kp": "N m",
        "drivetrain.motors[0].controller.ki": "N m s",  # integral of the torque error
    }
    for path, times in cases.items():
        torque = q(parameter_unit(path, cfg)) * q(times)
        assert torque.to_base_units() == q("N m"), path
    assert parameter_unit("drivetrain.shafts[2].damping_ratio") == "1"
    with pytest.raises(ValueError, match="controller type"):
        parameter_unit("drivetrain.motors[0].controller.kp")
