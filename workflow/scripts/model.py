"""Rule `model`: state-space models, modes and FRFs of one gearbox and of the bench, and the
true FRFs and modes of every identification pairing (read by the identify stage)."""

from gbpipe import io, model

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
cfg, truth_cfg = snakemake.params.model, snakemake.params.truth
ds = model.model_datasets(cfg, truth_cfg)

io.write(ds["gearbox"], snakemake.output.gearbox, sources=snakemake.input, stage="model",
         config=cfg, title="Torsional model of one gearbox")
log.info("gearbox modes [Hz]: %s", ds["gearbox"].mode_frequency.values.round(2))
io.write(ds["bench"], snakemake.output.bench, sources=snakemake.input, stage="model",
         config=cfg, title="Torsional model of the back-to-back bench, open and closed loop")
log.info("bench closed-loop modes [Hz]: %s",
         ds["bench"].closed_mode_frequency.values.round(2))
io.write(ds["truth"], snakemake.output.truth, sources=snakemake.input,
         stage="model", config={**cfg, "identify": truth_cfg},
         title="True FRFs and modes of every identification pairing")
log.info("truth of %d pairings on %d frequencies", ds["truth"].sizes["pairing"],
         ds["truth"].sizes["frequency"])
