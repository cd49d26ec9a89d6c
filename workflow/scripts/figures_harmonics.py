"""Rule `figures_harmonics`: figures 11-17 and the resonance-band check, with captions."""

from gbpipe import io
from gbpipe.figures.style import formats
from gbpipe.figures.waterfalls import harmonics_figures

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p = snakemake.params
variants = {n: io.read(f) for n, f in zip(p.variants, snakemake.input.variants, strict=True)}
with formats(p.formats):  # config figures.formats
    harmonics_figures(io.read(snakemake.input.raw), variants, dict(snakemake.output.items()),
                      n_cycles=p.n_cycles, stages=p.stages)
log.info("wrote figures 11-17 and the mode-band figure")
