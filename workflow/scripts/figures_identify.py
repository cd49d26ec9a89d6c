"""Rule `figures_identify`: Fig 6 and the match-bandwidth figure, with report captions."""

import csv

from gbpipe import io
from gbpipe.figures.identification_plots import identification_figures
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
with open(snakemake.input.table) as fh:
    rows = list(csv.DictReader(fh))
with formats(snakemake.params.formats):  # config figures.formats
    bws = identification_figures([io.read(p) for p in snakemake.input.models],
                                 snakemake.params.best, rows, dict(snakemake.output.items()))
log.info("figures: %s", bws)
