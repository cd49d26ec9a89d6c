"""Rule `spectra`: waterfalls of the raw sweep."""

from gbpipe import io, runlog
from gbpipe.harmonics import waterfalls

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
spec = snakemake.params.spectra
sw = io.read(snakemake.input.sweep)
x = sw[spec["signal"]]
ds = waterfalls(x.values.astype(float), float(sw.attrs["sample_rate"]), sw.pulse_time.values,
                spec, pulses_per_rev=int(sw.attrs["pulses_per_rev"]), units=x.attrs["units"],
                long_name=x.attrs["long_name"])
io.write(ds, snakemake.output[0], stage="spectra", config=spec,
         title="Power and order spectra vs rpm of the raw sweep")
log.info("%d rpm bins x %d frequencies", ds.rpm.size, ds.frequency.size)
