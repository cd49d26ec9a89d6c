"""Rule `figures_tests`: figures 7-10 with their report captions."""

from gbpipe import io
from gbpipe.figures.style import formats
from gbpipe.figures.time_plots import ramp_test_figures

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
with formats(snakemake.params.formats):  # config figures.formats
    ramp_test_figures([io.read(p) for p in snakemake.input.speed],
                      [io.read(p) for p in snakemake.input.torque],
                      dict(snakemake.output.items()))
log.info("wrote figures 7-10")
