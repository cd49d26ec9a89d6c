"""Rule `removal_tests`: one harmonic-removal method on the measured-like signals of a test
record, for the identification version named after it."""

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
params = method_params({w.method: p.method_cfg}, w.method, families)
ds = method_residuals(record, p.signals, w.method, params, families, p.keep_below)
# the same removal on the known harmonic part alone: the family's leftover, free of the
# random part's own content at the orders
harmonic = harmonic_record(record, random, p.signals)
leftover = method_residuals(harmonic, p.signals, w.method, params, families, p.keep_below)
ds = record_separation(ds, harmonic, random, io.read(snakemake.input.bench), families,
                       p.spectra, leftover)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="removal_tests",
         config=dict(p), wildcards=dict(w.items()),
         title=f"Measured-like {w.test} ({w.profile}) after {w.method} harmonic removal")
log.info("%s (%s): removed %s by %s from %d signals; worst leftover %.1f dB, worst "
         "mode-band level change %.2f dB", w.test, w.profile, list(families), w.method,
         len(p.signals), float(ds.leftover_db.min()),
         float(abs(ds.change_db.sel(band=ds.band != "elsewhere")).max()))
