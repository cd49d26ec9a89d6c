"""Rule `identify_measured`: every pairing x data version of one bench record (or of the
pooled repeats of one test), one method, scored against the nonparametric FRF of the data
(no true model exists)."""

from pathlib import Path

from gbpipe import io
from gbpipe.identify import identify_record
from gbpipe.identify.orders import stabilization_orders

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg, i, par = snakemake.wildcards, snakemake.params.cfg, snakemake.input, snakemake.params
# lazy: only the signals the pairings use are read (bounded memory on long records)
records = [io.read(p, lazy=True) for p in i.records]
removed = [{"tsa": (io.read(p, lazy=True), None)} for p in i.tsa_records] or [{} for _ in records]
orders = provenance = None
if i.modes:  # identify.order: stabilization, from rule modes_measured
    orders, provenance = stabilization_orders(
        io.read(i.modes[0]), w.method, [p["name"] for p in cfg["identify"]["pairings"]],
        Path(i.modes[0]).name)
windows = [tuple(x) if x is not None else None for x in par.windows]
if par.group:  # the repeats of one test, pooled
    for rec in records:
        rec.attrs["group"] = par.group
    ds = identify_record(cfg, records, None, None, w.method, removed, orders=orders,
                         order_source=provenance, validation_window=windows,
                         line_orders=par.line_orders)
else:
    ds = identify_record(cfg, records[0], None, None, w.method, removed[0], orders=orders,
                         order_source=provenance, validation_window=windows[0],
                         line_orders=par.line_orders)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="identify_measured",
         config=cfg, wildcards={"record": w.record, "method": w.method},
         title=f"{w.method} models of bench record {w.record} vs its nonparametric FRF")
