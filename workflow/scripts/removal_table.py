"""Rule `removal_table`: one CSV row per removal method x record x signal x family x rpm
bin x band (the sweep, and the tests of the identification versions)."""

from gbpipe import io
from gbpipe.harmonics import removal_rows

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
rows = removal_rows([io.read(p) for p in [*snakemake.input.methods, *snakemake.input.tests]])
io.write_csv(rows, snakemake.output.table)
log.info("%d rows in %s", len(rows), snakemake.output.table)
