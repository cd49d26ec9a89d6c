"""Rule `tsa_measured`: harmonic removal by TSA on the signals of one bench record."""

from gbpipe import io
from gbpipe.harmonics import record_residuals

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg, what = snakemake.wildcards, snakemake.params.cfg, snakemake.params.what
# lazy: the record's other channels are never read (bounded memory on long records)
ds = record_residuals(io.read(snakemake.input.record, lazy=True), cfg["signals"], cfg["stages"],
                      cfg["tsa"], cfg["keep_below"])
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage=snakemake.rule, config=cfg,
         wildcards=dict(w.items()), title=f"{what} after TSA harmonic removal")
log.info("%s: removed %s from %d signals", what, ds.attrs["removed_cycles"],
         len(cfg["signals"]))
