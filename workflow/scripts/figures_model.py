"""Rule `figures_model`: figures 3, 4 and 5 with their report captions."""

from gbpipe import io
from gbpipe.figures.model_plots import model_figures
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
with formats(snakemake.params.formats):  # config figures.formats
    model_figures(io.read(snakemake.input.gearbox), io.read(snakemake.input.bench),
                  snakemake.params.model, dict(snakemake.output.items()))
log.info("wrote figures 3-5")
