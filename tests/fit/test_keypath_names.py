"""Key paths of the fit through mappings of named entries (a general drivetrain's
``drivetrain.disks.load.inertia``) as well as indexed lists."""

from __future__ import annotations

import copy

from gbpipe.model.fit_report import parameter_unit
from gbpipe.model.keypath import get_value, overlay, with_values


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
