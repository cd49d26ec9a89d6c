"""Rule `measured`: one bench record, files -> checked, SI, common grid -> NetCDF.

Written block by block straight into the output (bounded memory on long records)."""

from gbpipe import io
from gbpipe.measured import read

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, p = snakemake.wildcards, snakemake.params
ds = read(p.spec, ".", name=w.record, min_duration=p.min_duration, out=snakemake.output.record,
          provenance={"stage": "measured", "config": p.spec, "wildcards": {"record": w.record},
                      "title": f"Bench record {w.record}: measured signals on a common "
                               "time grid"})
log.info("%s: %d samples at %g Hz, signals %s", w.record, ds.sizes["time"],
         ds.attrs["sample_rate"], ", ".join(map(str, ds.data_vars)))
