"""Rule `tsa`: one TSA variant on the sweep; residual, waterfalls and removal metrics."""

from gbpipe import io
from gbpipe.harmonics import tsa_variant

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, w = snakemake.params, snakemake.wildcards
ds = tsa_variant(io.read(snakemake.input.sweep), io.read(snakemake.input.bench), w.variant,
                 p.tsa, p.spectra, p.stages, p.excitation, p.noise)
io.write(ds, snakemake.output.nc, sources=snakemake.input,
         stage="tsa", config=dict(p), wildcards={"variant": w.variant},
         float32=True, title=f"TSA harmonic removal on the sweep, variant {w.variant}")
if "cascade_attenuation" in ds:
    log.info("cascade attenuation: %s dB", ", ".join(
        f"{f} {a:.1f}" for f, a in zip(ds.family.values, ds.cascade_attenuation.values,
                                       strict=True)))
