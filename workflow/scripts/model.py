"""Rule `model`: state-space models, modes and FRFs of one gearbox and of the bench, and the
true FRFs and modes of every identification pairing (read by the identify stage)."""

from gbpipe import io, model
from gbpipe.model.dataset import frequency_grid, statespace_dataset

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
cfg = snakemake.params.model
f = frequency_grid(**cfg["model"]["frf"])

gb_mech, _ = model.gearbox_mechanism(cfg)
gb = statespace_dataset(model.gearbox_ss(cfg), f, mech=gb_mech)
gb.attrs["gear_damping_note"] = (
    "gears are rigid: the gear damping ratio has no relative coordinate to act on and is "
    "not used")
io.write(gb, snakemake.output.gearbox, stage="model", config=cfg,
         title="Torsional model of one gearbox")
log.info("gearbox modes [Hz]: %s", gb.mode_frequency.values.round(2))

plant = model.bench_ss(cfg, closed=False)
closed = model.bench_ss(cfg)
b_mech, _ = model.bench_mechanism(cfg)
ds = statespace_dataset(plant, f, prefix="plant_", mech=b_mech,
                        frf_inputs=["motor_torque_driver", "motor_torque_driven"],
                        frf_outputs=["speed_gb1_hss", "speed_gb2_hss", "speed_lss",
                                     "torque_meter_driving", "torque_meter_driven"])
ds = ds.merge(statespace_dataset(
    closed, f, prefix="closed_",
    frf_inputs=["speed_ref", "torque_ref", "disturbance_driver", "disturbance_driven"],
    frf_outputs=["speed_gb1_hss", "speed_gb2_hss", "speed_lss", "torque_meter_driving",
                 "torque_meter_driven", "motor_torque_driver", "motor_torque_driven"]))
io.write(ds, snakemake.output.bench, stage="model", config=cfg,
         title="Torsional model of the back-to-back bench, open and closed loop")
log.info("bench closed-loop modes [Hz]: %s", ds.closed_mode_frequency.values.round(2))

truth_cfg = snakemake.params.truth
truth = model.truth_dataset(cfg, truth_cfg["pairings"], frequency_grid(**truth_cfg["frf"]),
                            truth_cfg["frf"]["f_max"], truth_cfg["zeta_max"])
io.write(truth, snakemake.output.truth, stage="model", config={**cfg, "identify": truth_cfg},
         title="True FRFs and modes of every identification pairing")
log.info("truth of %d pairings on %d frequencies", truth.sizes["pairing"],
         truth.sizes["frequency"])
