"""Rule `virtual_table`: one CSV row per record and held-out sensor (columns
gbpipe.virtual.TABLE_COLUMNS): fit with and without the means, RMS error, 95 % coverage."""

from gbpipe import io
from gbpipe.virtual import table_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
rows = []
for path in snakemake.input.nc:
    ds = io.read(path, lazy=True)   # the statistics and the steady flags, not the series
    rows += table_rows(ds, ds.attrs["wildcard_record"])
io.write_csv(rows, snakemake.output.table)
log.info("%d held-out signals in %s", len(rows), snakemake.output.table)
