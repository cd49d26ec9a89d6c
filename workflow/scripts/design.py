"""Rule `design`: predicted output SNR, coherence, FRF error and identifiable band of every
identification pairing and data version for every test and profile, from the bench model,
the test's set-points, the noise spectra and the gear excitation, before identification
runs (docs/design.md)."""

from gbpipe import identify, io, model, simulate

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
cfg = snakemake.params.cfg
bench = model.bench_ss(cfg)
truths = {p["name"]: model.truth_model(cfg, p["inputs"], p["outputs"])
          for p in cfg["identify"]["pairings"]}
for (test, profile), path in zip(snakemake.params.records, snakemake.output.nc, strict=True):
    # a ramp test's set-points, or a designed test's (its base test's plus the signal)
    _, speed_ref, torque_ref = simulate.designed_reference(cfg, test, profile)
    ds = identify.predict_test(cfg, bench, truths, speed_ref, torque_ref,
                               float(cfg["campaign"]["sample_rate"]))
    io.write(ds, path, sources=snakemake.input, stage=snakemake.rule, config=dict(cfg),
             wildcards={"test": test, "profile": profile},
             title=f"Predicted identifiable band of every pairing, test {test}, "
                   f"{profile} steps")
    for version in ds.version.values:
        for name in ds.pairing.values:
            d = ds.sel(version=version, pairing=name)
            by = ", ".join(f"{s} {x:.0%}" for s, x in zip(
                ds.source.values, d.excitation_share.values, strict=True) if x >= 0.01)
            log.info("%s %s %-10s: %-14s predicted band %6.1f Hz (excited by %s)", test,
                     profile, version, name, d.predicted_hz, by or "nothing")
