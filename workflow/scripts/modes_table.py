"""Rule `modes_table_measured`: one CSV row per cluster of every bench record's stabilization
diagrams (columns gbpipe.identify.TABLE_COLUMNS), and one per mode of every group of
repeats (gbpipe.identify.GROUP_COLUMNS)."""

from gbpipe import io
from gbpipe.identify import group_table_rows, modes_table_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
rows = []
for path in snakemake.input.modes:
    ds = io.read(path)
    rows += modes_table_rows(ds, ds.attrs["wildcard_record"])
io.write_csv(rows, snakemake.output.table)
groups = group_table_rows(rows, snakemake.params.groups, snakemake.params.tolerance)
io.write_csv(groups, snakemake.output.groups)
log.info("%d clusters in %s, %d in %s", len(rows), snakemake.output.table, len(groups),
         snakemake.output.groups)
