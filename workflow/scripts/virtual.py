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
# lazy: only the channels the estimator reads are loaded, the held-out and measured
# torques block by block; the output is written as the smoother makes it (hour-long records)
virtual_record(p.virtual, model, io.read(i.record, lazy=True), record, snakemake.output.nc,
               signals=p.signals,
               provenance={"sources": i, "stage": snakemake.rule, "config": dict(p),
                           "wildcards": {"record": record},
                           "title": f"Virtual torque sensors of {record}: estimates, 95 % "
                                    "bands, load spectra"})
