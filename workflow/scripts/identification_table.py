"""Rule `identification_table`: one CSV row per stored model of every identify job, with
the band the design step predicted for it."""

from gbpipe import io
from gbpipe.identify import table_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
designs = {}
# bench records have no design step (rule identification_table_measured): no designs
for path in getattr(snakemake.input, "designs", []):
    ds = io.read(path)
    designs[(ds.attrs["wildcard_test"], ds.attrs["wildcard_profile"])] = ds
rows = table_rows([io.read(p) for p in snakemake.input.models], designs)
io.write_csv(rows, snakemake.output.table)
log.info("%d models in %s", len(rows), snakemake.output.table)
