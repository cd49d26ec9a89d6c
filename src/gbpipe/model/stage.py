"""The model stage as data: the gearbox, bench and truth datasets the ``model`` rule writes.

:func:`model_datasets` builds the three datasets of ``results/model/`` (gearbox.nc,
bench.nc, truth.nc) from the configuration; the workflow script only writes them
(docs/architecture.md, "Stage graph").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import xarray as xr

from gbpipe.model.assembly import bench_chain, bench_ss, gearbox_ss
from gbpipe.model.dataset import frequency_grid, statespace_dataset
from gbpipe.model.drivetrain import gearbox_mechanism
from gbpipe.model.truth import truth_dataset

__all__ = ["model_datasets", "GEAR_DAMPING_NOTE", "PLANT_FRF_INPUTS", "PLANT_FRF_OUTPUTS",
           "CLOSED_FRF_INPUTS", "CLOSED_FRF_OUTPUTS"]

#: Attribute ``gear_damping_note`` of the gearbox dataset.
GEAR_DAMPING_NOTE = (
    "gears are rigid: the gear damping ratio has no relative coordinate to act on and is "
    "not used")

#: Inputs and outputs of the open-loop plant FRFs stored in the bench dataset.
PLANT_FRF_INPUTS = ("motor_torque_driver", "motor_torque_driven")
PLANT_FRF_OUTPUTS = ("speed_gb1_hss", "speed_gb2_hss", "speed_lss", "torque_meter_driving",
                     "torque_meter_driven")
#: Inputs and outputs of the closed-loop FRFs stored in the bench dataset.
CLOSED_FRF_INPUTS = ("speed_ref", "torque_ref", "disturbance_driver", "disturbance_driven")
CLOSED_FRF_OUTPUTS = ("speed_gb1_hss", "speed_gb2_hss", "speed_lss", "torque_meter_driving",
                      "torque_meter_driven", "motor_torque_driver", "motor_torque_driven")


def model_datasets(cfg: Mapping[str, Any], truth_cfg: Mapping[str, Any]
                   ) -> dict[str, xr.Dataset]:
    """State-space models, modes and FRFs of one gearbox and of the bench, and the truth.

    Parameters
    ----------
    cfg : mapping
        Validated configuration sections ``gearbox``, ``bench`` and ``model``
        (``model.frf``: ``f_min`` [Hz], ``f_max`` [Hz], ``points`` of the FRF grid).
    truth_cfg : mapping
        ``identify`` sections ``pairings``, ``frf`` (identification grid: ``f_min`` [Hz],
        ``f_max`` [Hz], ``points``; ``f_max`` is also the highest mode kept) and
        ``zeta_max`` (highest damping ratio kept [-]).

    Returns
    -------
    dict of str -> xarray.Dataset
        ``gearbox``: one gearbox free at both ends (matrices, modes [Hz], undamped
        frequencies [Hz], FRFs on the model grid, attribute ``gear_damping_note``);
        ``bench``: open-loop plant (prefix ``plant_``) and closed-loop bench (prefix
        ``closed_``) with the FRFs of :data:`PLANT_FRF_INPUTS` x :data:`PLANT_FRF_OUTPUTS`
        and :data:`CLOSED_FRF_INPUTS` x :data:`CLOSED_FRF_OUTPUTS` (with a ``drivetrain:``,
        its motor torques x sensors, and its references and disturbances x sensors and
        motor torques);
        ``truth``: :func:`gbpipe.model.truth_dataset` of every identification pairing.
    """
    f = frequency_grid(**cfg["model"]["frf"])

    gb_mech, _ = gearbox_mechanism(cfg)
    gearbox = statespace_dataset(gearbox_ss(cfg), f, mech=gb_mech)
    gearbox.attrs["gear_damping_note"] = GEAR_DAMPING_NOTE

    b_mech = bench_chain(cfg).mechanism
    plant, closed = bench_ss(cfg, closed=False), bench_ss(cfg)
    if cfg.get("drivetrain"):
        # a described chain: its own motors and sensors (the excitation angles left out,
        # as the paper's lists leave them)
        motors = [u for u in plant.inputs if u.startswith("motor_torque_")]
        plant_io = (motors, plant.outputs)
        closed_io = ([u for u in closed.inputs if u not in plant.inputs], closed.outputs)
    else:
        plant_io = (list(PLANT_FRF_INPUTS), list(PLANT_FRF_OUTPUTS))
        closed_io = (list(CLOSED_FRF_INPUTS), list(CLOSED_FRF_OUTPUTS))
    bench = statespace_dataset(plant, f, prefix="plant_", mech=b_mech,
                               frf_inputs=list(plant_io[0]), frf_outputs=list(plant_io[1]))
    bench = bench.merge(statespace_dataset(closed, f, prefix="closed_",
                                           frf_inputs=list(closed_io[0]),
                                           frf_outputs=list(closed_io[1])))

    truth = truth_dataset(cfg, truth_cfg["pairings"], frequency_grid(**truth_cfg["frf"]),
                          truth_cfg["frf"]["f_max"], truth_cfg["zeta_max"])
    return {"gearbox": gearbox, "bench": bench, "truth": truth}
