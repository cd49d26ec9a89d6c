"""Rule `design`: predicted output SNR, coherence, FRF error and identifiable band of every
identification pairing for one test, from the bench model, the test's set-points and the
noise spectra, before identification runs (docs/design.md)."""

from gbpipe import identify, io, model, simulate

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
cfg, w = snakemake.params.cfg, snakemake.wildcards
# a ramp test's set-points, or a designed test's (its base test's plus the designed signal)
_, speed_ref, torque_ref = simulate.designed_reference(cfg, w.test, w.profile)
truths = {p["name"]: model.truth_model(cfg, p["inputs"], p["outputs"])
          for p in cfg["identify"]["pairings"]}
ds = identify.predict_test(cfg, model.bench_ss(cfg), truths, speed_ref, torque_ref,
                           float(cfg["campaign"]["sample_rate"]))
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage=snakemake.rule,
         config=dict(cfg), wildcards={"test": w.test, "profile": w.profile},
         title=f"Predicted identifiable band of every pairing, test {w.test}, "
               f"{w.profile} steps")
for name in ds.pairing.values:
    d = ds.sel(pairing=name)
    by = ", ".join(f"{s} {x:.0%}" for s, x in zip(ds.source.values, d.excitation_share.values,
                                                  strict=True) if x >= 0.01)
    log.info("%-14s predicted band %6.1f Hz (excited by %s)", name, d.predicted_hz,
             by or "nothing")
