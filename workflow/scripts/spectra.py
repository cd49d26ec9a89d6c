"""Rule `spectra`: waterfalls of the raw sweep."""

from gbpipe import io
from gbpipe.harmonics import sweep_waterfalls

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
spec = snakemake.params.spectra
ds = sweep_waterfalls(io.read(snakemake.input.sweep), spec)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="spectra", config=spec,
         title="Power and order spectra vs rpm of the raw sweep")
log.info("%d rpm bins x %d frequencies", ds.rpm.size, ds.frequency.size)
