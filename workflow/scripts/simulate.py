"""Rule `campaign`: every closed-loop test record the workflow reads, clean and
measured-like, and the random-only twins (the same simulation, same seeds, without the
angle-locked excitation) of the exact separation metric, in one job."""

from gbpipe import io, simulate

# The clean series stay float64, exactly as simulated: they are the noise-free reference of
# the clean identification version (float32's 4e-6 rad/s at 117 rad/s is as large as the
# cross-path speed response near 100 Hz), and float32 motor torques (rounding 110 dB under
# their ripple) still moved a closed-loop MOESP bandwidth by 4 %. The measured-like series
# carry sensor noise: each is float32 where its own spectrum lies 40 dB above float32's
# rounding at every frequency (gbpipe.io.write, noisy).

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, out = snakemake.params, snakemake.output
# params.records is in the order of the outputs: every record, then every twin. Each file
# is written as soon as it is simulated (atomically): a failed job's outputs are removed by
# Snakemake, and 20-odd records held until the end would need ~1 GB
for rec, path in zip(p.records, [*out.nc, *out.random], strict=True):
    test, profile = rec["test"], rec["profile"]
    cfg = simulate.random_only(p.cfg) if rec["random"] else p.cfg
    ds = simulate.test(cfg, test, profile)
    pulses = ds.sizes.get("pulse", 0)
    what = (", random-only (no angle-locked excitation, same seeds)" if rec["random"]
            else "")
    if rec["random"]:
        # a twin serves the exact separation metric only, which reads its measured-like
        # series (gbpipe.harmonics.harmonic_record, record_separation): the rest would
        # double the record's bulk for nothing
        ds = ds[[v for v in ds.data_vars if str(v).endswith("_measured")]]
    io.write(ds, path, sources=snakemake.input, stage="simulate", config={"cfg": p.cfg},
             wildcards={"test": test, "profile": profile},
             noisy=[v for v in ds.data_vars if str(v).endswith("_measured")],
             title=f"Closed-loop bench test {test}, {profile} steps{what}")
    log.info("%s/%s%s: %d samples, %d tachometer pulses", test, profile,
             " (random-only)" if rec["random"] else "", ds.time.size, pulses)
