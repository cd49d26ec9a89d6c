"""Rule `removal_tests`: TSA and every harmonic-removal method of the identification
versions on the measured-like signals of every record identified (and its validation
record), one file per record and version."""

from gbpipe import io
from gbpipe.harmonics import (
    envelope_modes,
    harmonic_record,
    method_params,
    method_residuals,
    record_residuals,
    record_separation,
    test_families,
)

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i, out = snakemake.params, snakemake.input, snakemake.output
families = test_families(p.families_cfg) if p.method_cfg else None
bench = io.read(i.bench) if p.method_cfg else None
# the random-only twins exist exactly when there are removal versions (rule campaign)
twins = list(i.random) or [None] * len(p.records)
# every record and version before any file: a failure leaves no output
done = []  # per record: (test, profile, record file, twin file, tsa, {method: dataset})
for n, ((test, profile), path, twin) in enumerate(
        zip(p.records, i.record, twins, strict=True), 1):
    record = io.read(path)
    what = f"Measured-like {test} ({profile})"
    tsa = record_residuals(record, p.signals, p.tsa_cfg["stages"], p.tsa_cfg["tsa"],
                           p.keep_below)
    log.info("[%d/%d] %s: removed %s by TSA from %d signals", n, len(p.records), what,
             tsa.attrs["removed_cycles"], len(p.signals))
    versions = {}
    if p.method_cfg:
        random = io.read(twin)
        # the known harmonic part alone: each method's leftover on it is free of the random
        # part's own content at the orders
        harmonic = harmonic_record(record, random, p.signals)
        for method in p.method_cfg:
            params = method_params(p.method_cfg, method, families,
                                   envelope_modes(bench, p.spectra))
            # the record and its harmonic part in one call (the regression's regressors
            # and factor built once for both); the harmonic part's speeds are no speeds:
            # the record's give the second angle
            ds, leftover = method_residuals([record, harmonic], p.signals, method, params,
                                            families, p.keep_below)
            versions[method] = ds = record_separation(ds, harmonic, random, bench, families,
                                                      p.spectra, leftover)
            log.info("[%d/%d] %s: removed %s by %s from %d signals; worst leftover %.1f dB, "
                     "worst mode-band level change %.2f dB", n, len(p.records), what,
                     list(families), method, len(p.signals), float(ds.leftover_db.min()),
                     float(abs(ds.change_db.sel(band=ds.band != "elsewhere")).max()))
    done.append((test, profile, path, twin, tsa, versions))

# each removal version's file: the config slice it depends on (not TSA's)
slice_keys = ("method_cfg", "families_cfg", "signals", "keep_below", "spectra")
config = {k: getattr(p, k) for k in slice_keys}
nc = iter(out.nc)
for (test, profile, path, twin, tsa, versions), tsa_path in zip(done, out.tsa, strict=True):
    wildcards = {"test": test, "profile": profile}
    what = f"Measured-like {test} ({profile})"
    # the signals after removal keep the records' sensor noise: float32 where it leaves room
    io.write(tsa, tsa_path, sources=[path, *i.code], stage="removal_tests",
             noisy=[v for v in tsa.data_vars if tsa[v].dims == ("time",)],
             config={"tsa": p.tsa_cfg["tsa"], "stages": p.tsa_cfg["stages"],
                     "signals": p.signals, "keep_below": p.keep_below},
             wildcards=wildcards, title=f"{what} after TSA harmonic removal")
    for method, ds in versions.items():
        io.write(ds, next(nc), sources=[path, twin, i.bench, *i.code], stage="removal_tests",
                 config=config, wildcards={**wildcards, "method": method},
                 noisy=[v for v in ds.data_vars if ds[v].dims == ("time",)],
                 title=f"{what} after {method} harmonic removal")
