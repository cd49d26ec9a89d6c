"""Rule `removal_table`: one CSV row per removal method x family x rpm bin x band."""

from gbpipe import io
from gbpipe.harmonics import removal_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
rows = removal_rows([io.read(p) for p in snakemake.input.methods])
io.write_csv(rows, snakemake.output.table)
log.info("%d rows in %s", len(rows), snakemake.output.table)
