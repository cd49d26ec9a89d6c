"""Rules `simulate` and `simulate_with_random`: one closed-loop test variant, clean and
measured-like; with `simulate_with_random` also the same simulation (same seeds) without
the angle-locked excitation, the random-only twin of the exact separation metric."""

from gbpipe import io, simulate

# float64: at 117 rad/s float32 resolves only 8e-6 rad/s, as large as the cross-path speed
# response near 100 Hz that identification needs

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, p, out = snakemake.wildcards, snakemake.params, snakemake.output
records = {"nc": (p.cfg, f"Closed-loop bench test {w.test}, {w.profile} steps")}
if "random" in out.keys():
    records["random"] = (simulate.random_only(p.cfg),
                         f"Closed-loop bench test {w.test}, {w.profile} steps, random-only "
                         "(no angle-locked excitation, same seeds)")
# every record simulated before any file is written: a failure leaves no output
done = {key: simulate.test(cfg, w.test, w.profile) for key, (cfg, _) in records.items()}
for key, ds in done.items():
    io.write(ds, out[key], sources=snakemake.input, stage=snakemake.rule, config=dict(p),
             wildcards={"test": w.test, "profile": w.profile}, title=records[key][1])
    log.info("%s/%s (%s): %d samples, %d tachometer pulses", w.test, w.profile, key,
             ds.time.size, ds.sizes.get("pulse", 0))
