"""Rules `sweep` and `sweep_random`: the constant-torque speed sweep with harmonics and
tachometer pulses; or the same simulation (same seeds) with the angle-locked excitation
off, the random-only sweep of the exact separation metric."""

from gbpipe import io, simulate

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p = snakemake.params
cfg = simulate.random_only(p.cfg) if p.random_only else p.cfg
what = "random-only (no angle-locked excitation)" if p.random_only else "measured-like"
ds = simulate.sweep(cfg)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage=snakemake.rule,
         config=dict(p), float32=True, title=f"Speed sweep at constant torque, {what}")
log.info("%s sweep: %d samples, %d pulses, %.0f-%.0f rpm", what, ds.time.size, ds.pulse.size,
         float(ds.rpm.min()), float(ds.rpm.max()))
