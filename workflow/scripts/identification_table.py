"""Rule `identification_table`: one CSV row per stored model of every identify job."""

from gbpipe import io
from gbpipe.identify import table_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
rows = table_rows([io.read(p) for p in snakemake.input.models])
io.write_csv(rows, snakemake.output.table)
log.info("%d models in %s", len(rows), snakemake.output.table)
