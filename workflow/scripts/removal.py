"""Rule `removal`: every harmonic-removal method on the sweep, each scored by the exact
separation metric against the random-only sweep."""

from gbpipe import io
from gbpipe.harmonics import (
    compare_method,
    envelope_modes,
    excitation_families,
    method_params,
)

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i = snakemake.params, snakemake.input
families = excitation_families(p.families_cfg)
# lazy: of the two sweeps' 20 series only the analysed signal, the pulses and the speeds
# of the second angle are read (each method reads them again: a few of 40 decompressed)
sweep, random = io.read(i.sweep, lazy=True), io.read(i.random, lazy=True)
bench = io.read(i.bench)
# every method before any file: a failed method leaves no output
done = {}
for method, method_cfg in p.method_cfg.items():
    # compare_method logs each method's time, peak memory and worst-bin attenuation
    done[method] = compare_method(sweep, random, bench, method,
                                  method_params({method: method_cfg}, method, families,
                                                envelope_modes(bench, p.spectra)),
                                  families, p.spectra)
for (method, ds), path in zip(done.items(), snakemake.output.nc, strict=True):
    # each file's provenance: the config slice of its own method, as one job per method had
    io.write(ds, path, sources=snakemake.input, stage="removal",
             config={"method_cfg": p.method_cfg[method], "families_cfg": p.families_cfg,
                     "spectra": p.spectra},
             wildcards={"method": method}, float32=True,
             # the residual keeps the sweep's sensor noise: only the bits it leaves room for
             noisy=[v for v in ds.data_vars if ds[v].dims == ("time",)],
             title=f"Harmonic removal by {method} on the sweep, against the random-only sweep")
