"""Rule `figures_removal`: attenuation against broadband distortion of every method."""

from gbpipe import io
from gbpipe.figures.removal_plots import removal_tradeoff_figure
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
datasets = {m: io.read(p) for m, p in zip(snakemake.params.methods, snakemake.input.methods,
                                          strict=True)}
out = {"png": snakemake.output.removal_tradeoff_png,
       "caption": snakemake.output.removal_tradeoff_caption}
with formats(snakemake.params.formats):  # config figures.formats
    numbers = removal_tradeoff_figure(datasets, out)
log.info("removal trade-off: %s", numbers)
