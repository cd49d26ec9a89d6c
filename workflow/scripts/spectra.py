"""Rules `spectra` and `spectra_measured`: waterfalls of the raw sweep or a bench record."""

from gbpipe import io
from gbpipe.harmonics import sweep_waterfalls

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
spec = snakemake.params.spectra
# lazy: of a bench record's channels only the analysed one and the tacho are read
ds = sweep_waterfalls(io.read(snakemake.input.record, lazy=True), spec)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="spectra", config=spec,
         title=f"Power and order spectra vs rpm of the {snakemake.params.what}")
log.info("%d rpm bins x %d frequencies", ds.rpm.size, ds.frequency.size)
