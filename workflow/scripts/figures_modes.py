"""Rule `figures_modes`: the stabilization diagram of every pairing of one bench record."""

from gbpipe import io
from gbpipe.figures.stabilization_plots import stabilization_figure
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
ds = io.read(snakemake.input.modes)
with formats(snakemake.params.formats):  # config figures.formats
    for pairing in snakemake.params.pairings:
        numbers = stabilization_figure(ds, pairing, snakemake.wildcards.record,
                                       {"png": snakemake.output[f"{pairing}_png"],
                                        "caption": snakemake.output[f"{pairing}_caption"]})
        log.info("%s: %s", pairing, numbers)
