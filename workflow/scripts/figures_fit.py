"""Rule `figures_fit`: one record's identified FRFs with bounds, the prior and the fitted
model, and the parameter table with 95 % intervals (docs/fit.md)."""

from gbpipe import io
from gbpipe.figures.fit_plots import fig_fit
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
out = snakemake.output
with formats(snakemake.params.formats):  # config figures.formats
    numbers = fig_fit(io.read(snakemake.input.nc), out.fig_fit_png, out.fig_fit_caption,
                      snakemake.wildcards.record)
log.info("fit figure: %s", numbers)
