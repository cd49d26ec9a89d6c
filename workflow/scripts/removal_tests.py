"""Rule `removal_tests`: every harmonic-removal method of the identification versions on
the measured-like signals of one test record, one file per method."""

from gbpipe import io
from gbpipe.harmonics import (
    harmonic_record,
    method_params,
    method_residuals,
    record_separation,
    test_families,
)

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, w = snakemake.params, snakemake.wildcards
families = test_families(p.families_cfg)
record, random = io.read(snakemake.input.record), io.read(snakemake.input.random)
bench = io.read(snakemake.input.bench)
# the known harmonic part alone: each method's leftover on it is free of the random part's
# own content at the orders
harmonic = harmonic_record(record, random, p.signals)
done = {}
for method in p.method_cfg:  # every method before any file: a failure leaves no output
    params = method_params(p.method_cfg, method, families)
    ds = method_residuals(record, p.signals, method, params, families, p.keep_below)
    leftover = method_residuals(harmonic, p.signals, method, params, families, p.keep_below)
    done[method] = ds = record_separation(ds, harmonic, random, bench, families, p.spectra,
                                          leftover)
    log.info("%s (%s): removed %s by %s from %d signals; worst leftover %.1f dB, worst "
             "mode-band level change %.2f dB", w.test, w.profile, list(families), method,
             len(p.signals), float(ds.leftover_db.min()),
             float(abs(ds.change_db.sel(band=ds.band != "elsewhere")).max()))
for (method, ds), path in zip(done.items(), snakemake.output.nc, strict=True):
    io.write(ds, path, sources=snakemake.input, stage="removal_tests", config=dict(p),
             wildcards={**dict(w.items()), "method": method},
             title=f"Measured-like {w.test} ({w.profile}) after {method} harmonic removal")
