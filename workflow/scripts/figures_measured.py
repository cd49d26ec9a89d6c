"""Rule `figures_measured`: identified models of one bench record against its data."""

from gbpipe import io
from gbpipe.figures.measured_plots import measured_identification_figure
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
with formats(snakemake.params.formats):  # config figures.formats
    bws = measured_identification_figure([io.read(p) for p in snakemake.input.models],
                                         snakemake.wildcards.record,
                                         snakemake.params.coherence_min,
                                         {"png": snakemake.output.fig_png,
                                          "caption": snakemake.output.caption})
log.info("match bandwidths: %s", bws)
