"""Rule `figures_removal_crossing`: the mode band at the worst order/mode crossing, in the
record, its random-only twin and every method's residual."""

from gbpipe import io
from gbpipe.figures.removal_plots import removal_crossing_figure
from gbpipe.figures.style import formats
from gbpipe.units import label_units

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i = snakemake.params, snakemake.input
datasets = {m: io.read(path) for m, path in zip(p.methods, i.methods, strict=True)}
# lazy: of the two sweeps' 20 series only the signal and the pulses are read
sweep, random = io.read(i.sweep, lazy=True), io.read(i.random, lazy=True)
sig = sweep[p.signal]  # spectra.signal, as rule removal reads it
out = {"png": snakemake.output.removal_crossing_png,
       "caption": snakemake.output.removal_crossing_caption}
with formats(p.formats):  # config figures.formats
    numbers = removal_crossing_figure(
        datasets, sig.values, random[p.signal].values,
        float(sweep.attrs["sample_rate"]), sweep.pulse_time.values, out,
        pulses_per_rev=int(sweep.attrs["pulses_per_rev"]), units=label_units(sig.attrs["units"]))
log.info("removal at the worst crossing: %s", numbers)
