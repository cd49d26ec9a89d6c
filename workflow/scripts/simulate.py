"""Rules `simulate` and `simulate_random`: one closed-loop test variant, clean and
measured-like; or the same simulation (same seeds) without the angle-locked excitation,
the random-only test of the exact separation metric."""

from gbpipe import io, simulate

# float64: at 117 rad/s float32 resolves only 8e-6 rad/s, as large as the cross-path speed
# response near 100 Hz that identification needs

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w = snakemake.wildcards
p = snakemake.params
ds = simulate.test(simulate.random_only(p.cfg) if p.random_only else p.cfg, w.test, w.profile)
io.write(ds, snakemake.output.nc, sources=snakemake.input,
         stage=snakemake.rule, config=dict(p),
         wildcards={"test": w.test, "profile": w.profile},
         title=f"Closed-loop bench test {w.test}, {w.profile} steps")
log.info("%s/%s: %d samples, %d tachometer pulses", w.test, w.profile, ds.time.size,
         ds.sizes.get("pulse", 0))
