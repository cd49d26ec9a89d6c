"""Rule `modes_table_measured`: one CSV row per cluster of every bench record's stabilization
diagrams (columns gbpipe.identify.TABLE_COLUMNS)."""

from gbpipe import io
from gbpipe.identify import modes_table_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
rows = []
for path in snakemake.input.modes:
    ds = io.read(path)
    rows += modes_table_rows(ds, ds.attrs["wildcard_record"])
io.write_csv(rows, snakemake.output.table)
log.info("%d clusters in %s", len(rows), snakemake.output.table)
