"""Rule `sweep`: constant-torque speed sweep with harmonics and tachometer pulses."""

from gbpipe import io, simulate

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
ds = simulate.sweep(snakemake.params.cfg)
io.write(ds, snakemake.output.nc, sources=snakemake.input,
         stage="sweep", config=snakemake.params.cfg, float32=True,
         title="Speed sweep at constant torque, measured-like")
log.info("sweep: %d samples, %d pulses, %.0f-%.0f rpm", ds.time.size, ds.pulse.size,
         float(ds.rpm.min()), float(ds.rpm.max()))
