"""Rule `sweep`: the constant-torque speed sweep with harmonics and tachometer pulses and,
for the removal comparison, the same simulation (same seeds) with the angle-locked
excitation off: the random-only sweep of the exact separation metric."""

from gbpipe import io, simulate

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, out = snakemake.params, snakemake.output
runs = [(False, out.nc)] + ([(True, out.random)] if out.random else [])
# each file written as soon as it is simulated (atomically): a failed job's outputs are
# removed by Snakemake, and holding both sweeps (1.2 M samples each) would double the peak
for random_only, path in runs:
    cfg = simulate.random_only(p.cfg) if random_only else p.cfg
    what = "random-only (no angle-locked excitation)" if random_only else "measured-like"
    ds = simulate.sweep(cfg)
    # the config slice of each file as when each had a job of its own
    io.write(ds, path, sources=snakemake.input, stage="sweep",
             config={"cfg": p.cfg, "random_only": random_only}, float32=True,
             # every series rounded as finely as its noise asks (the data decide: the
             # smooth speeds keep float32, the motor torques' broadband ripple 12 bits)
             noisy=[v for v in ds.data_vars if ds[v].dims == ("time",)],
             title=f"Speed sweep at constant torque, {what}")
    log.info("%s sweep: %d samples, %d pulses, %.0f-%.0f rpm", what, ds.time.size,
             ds.pulse.size, float(ds.rpm.min()), float(ds.rpm.max()))
