"""Rule `modes_measured`: stabilization diagrams, modes and model order of one bench record
(every pairing; docs/modal.md)."""

from gbpipe import io
from gbpipe.identify import record_modes

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg = snakemake.wildcards, snakemake.params.cfg
# lazy: only the pairings' and speeds' signals of the record are read (bounded memory on
# long records)
ds = record_modes(cfg, io.read(snakemake.input.record, lazy=True), snakemake.params.orders,
                  speeds=dict(snakemake.params.speeds))
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="modes_measured",
         config={**cfg, "orders": snakemake.params.orders,
                 "speeds": dict(snakemake.params.speeds)}, wildcards={"record": w.record},
         title=f"stabilization diagrams and modes of bench record {w.record}")
