"""Rule `tsa`: every TSA variant on the sweep; residual, waterfalls and removal metrics."""

from gbpipe import io
from gbpipe.harmonics import tsa_variant

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p = snakemake.params
sweep, bench = io.read(snakemake.input.sweep), io.read(snakemake.input.bench)
# every variant before any file: a failed variant leaves no output
done = {}
for variant, tsa in p.tsa.items():
    done[variant] = ds = tsa_variant(sweep, bench, variant, tsa, p.spectra, p.stages,
                                     p.excitation, p.noise)
    if "cascade_attenuation" in ds:
        log.info("%s: cascade attenuation: %s dB", variant, ", ".join(
            f"{f} {a:.1f}" for f, a in zip(ds.family.values, ds.cascade_attenuation.values,
                                           strict=True)))
config = {k: v for k, v in dict(p).items() if k not in ("tsa", "variants")}
for (variant, ds), path in zip(done.items(), snakemake.output.nc, strict=True):
    # each file's provenance: the config slice of its own variant, as one job per variant
    # had; the residual keeps the sweep's sensor noise: only the bits it leaves room for
    io.write(ds, path, sources=snakemake.input, stage="tsa",
             config={"tsa": p.tsa[variant], **config}, wildcards={"variant": variant},
             float32=True, noisy=[v for v in ds.data_vars if ds[v].dims == ("time",)],
             title=f"TSA harmonic removal on the sweep, variant {variant}")
