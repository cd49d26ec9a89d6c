"""Rule `removal`: one harmonic-removal method on the sweep, scored by the exact separation
metric against the random-only sweep."""

from gbpipe import io
from gbpipe.harmonics import compare_method, excitation_families, method_params

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, w = snakemake.params, snakemake.wildcards
families = excitation_families(p.families_cfg)
ds = compare_method(io.read(snakemake.input.sweep), io.read(snakemake.input.random),
                    io.read(snakemake.input.bench), w.method,
                    method_params({w.method: p.method_cfg}, w.method, families), families,
                    p.spectra)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="removal", config=dict(p),
         wildcards={"method": w.method}, float32=True,
         title=f"Harmonic removal by {w.method} on the sweep, against the random-only sweep")
