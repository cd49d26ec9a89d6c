"""Rule `figures_virtual`: one record's held-out sensors against their estimates and
95 % bands, and the load spectra of every torque (docs/virtual.md)."""

from gbpipe import io
from gbpipe.figures.style import formats
from gbpipe.figures.virtual_plots import fig_virtual

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
out = snakemake.output
# lazy: only the window shown of the series on time is read (hour-long records)
with formats(snakemake.params.formats):  # config figures.formats
    numbers = fig_virtual(io.read(snakemake.input.nc, lazy=True), out.fig_virtual_png,
                          out.fig_virtual_caption, snakemake.wildcards.record)
log.info("virtual figure: %s", numbers)
