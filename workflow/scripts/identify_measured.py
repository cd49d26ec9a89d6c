"""Rule `identify_measured`: every pairing x data version of one bench record, one method,
scored against the nonparametric FRF of the data (no true model exists)."""

from gbpipe import io
from gbpipe.identify import identify_record

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg, i = snakemake.wildcards, snakemake.params.cfg, snakemake.input
removed = {"tsa": (io.read(i.tsa_record[0]), None)} if i.tsa_record else {}
ds = identify_record(cfg, io.read(i.record), None, None, w.method, removed)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="identify_measured",
         config=cfg, wildcards={"record": w.record, "method": w.method},
         title=f"{w.method} models of bench record {w.record} vs its nonparametric FRF")
