"""Rules `identify` (one test x profile x method) and `identification_table` (all jobs)."""

from gbpipe import io, runlog, tables
from gbpipe.identify import identify_record, table_rows

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
if snakemake.rule == "identification_table":
    rows = table_rows([io.read(p) for p in snakemake.input.models])
    tables.write_csv(rows, snakemake.output[0])
    log.info("%d models in %s", len(rows), snakemake.output[0])
else:
    w, cfg, i = snakemake.wildcards, snakemake.params.cfg, snakemake.input
    ds = identify_record(cfg, io.read(i.record), io.read(i.validation), w.method,
                         io.read(i.tsa_record), io.read(i.tsa_validation))
    io.write(ds, snakemake.output[0], stage="identify", config=cfg,
             wildcards={"test": w.test, "profile": w.profile, "method": w.method},
             title=f"{w.method} models of {w.test} ({w.profile}) vs the true bench model")
