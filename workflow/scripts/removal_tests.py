"""Rule `removal_tests`: TSA and every harmonic-removal method of the identification
versions on the measured-like signals of one test record, one file per version."""

from gbpipe import io
from gbpipe.harmonics import (
    harmonic_record,
    method_params,
    method_residuals,
    record_residuals,
    record_separation,
    test_families,
)

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, w, i = snakemake.params, snakemake.wildcards, snakemake.input
record = io.read(i.record)
what = f"Measured-like {w.test} ({w.profile})"
# every version before any file: a failure leaves no output
tsa = record_residuals(record, p.signals, p.tsa_cfg["stages"], p.tsa_cfg["tsa"],
                       p.keep_below)
log.info("%s: removed %s by TSA from %d signals", what, tsa.attrs["removed_cycles"],
         len(p.signals))
done = {}
if p.method_cfg:
    families = test_families(p.families_cfg)
    random, bench = io.read(i.random), io.read(i.bench)
    # the known harmonic part alone: each method's leftover on it is free of the random
    # part's own content at the orders
    harmonic = harmonic_record(record, random, p.signals)
    for method in p.method_cfg:
        params = method_params(p.method_cfg, method, families)
        ds = method_residuals(record, p.signals, method, params, families, p.keep_below)
        leftover = method_residuals(harmonic, p.signals, method, params, families,
                                    p.keep_below)
        done[method] = ds = record_separation(ds, harmonic, random, bench, families,
                                              p.spectra, leftover)
        log.info("%s: removed %s by %s from %d signals; worst leftover %.1f dB, worst "
                 "mode-band level change %.2f dB", what, list(families), method,
                 len(p.signals), float(ds.leftover_db.min()),
                 float(abs(ds.change_db.sel(band=ds.band != "elsewhere")).max()))
wildcards = dict(w.items())
io.write(tsa, snakemake.output.tsa, sources=[i.record, *i.code], stage="removal_tests",
         config={"tsa": p.tsa_cfg["tsa"], "stages": p.tsa_cfg["stages"],
                 "signals": p.signals, "keep_below": p.keep_below},
         wildcards=wildcards, title=f"{what} after TSA harmonic removal")
# each removal version's file: the config slice it depends on (not TSA's)
slice_keys = ("method_cfg", "families_cfg", "signals", "keep_below", "spectra")
config = {k: getattr(p, k) for k in slice_keys}
for (method, ds), path in zip(done.items(), snakemake.output.nc, strict=True):
    io.write(ds, path, sources=snakemake.input, stage="removal_tests", config=config,
             wildcards={**wildcards, "method": method},
             title=f"{what} after {method} harmonic removal")
