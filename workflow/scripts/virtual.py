"""Rule `virtual`: one bench record's virtual torque sensors (docs/virtual.md): the chain
(as configured, or with the record's fitted overlay merged), the motor torques and chosen
sensors in, every wanted torque with its 95 % band, the held-out sensors compared and the
load spectra out."""

from gbpipe import io
from gbpipe.config import merge, read_yaml
from gbpipe.virtual import virtual_record

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i, record = snakemake.params, snakemake.input, snakemake.wildcards.record
model = merge(p.model, read_yaml(i.overlay)) if "overlay" in i.keys() else p.model
# lazy: only the channels the estimator reads are loaded (bounded memory on long records)
ds = virtual_record(p.virtual, model, io.read(i.record, lazy=True), record, p.signals)
io.write(ds, snakemake.output.nc, sources=i, stage=snakemake.rule, config=dict(p),
         wildcards={"record": record},
         title=f"Virtual torque sensors of {record}: estimates, 95 % bands, load spectra")
log.info("%s: %s; targets %s", record, ds.attrs["noise_source"],
         ", ".join(map(str, ds.target.values)))
