"""Rule `tsa_tests`: harmonic removal on the measured-like signals of one test record."""

from gbpipe import io
from gbpipe.harmonics import record_residuals

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg = snakemake.wildcards, snakemake.params.cfg
ds = record_residuals(io.read(snakemake.input.record), cfg["signals"], cfg["stages"],
                      cfg["tsa"], cfg["keep_below"])
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="tsa_tests", config=cfg,
         wildcards={"test": w.test, "profile": w.profile},
         title=f"Measured-like {w.test} ({w.profile}) after TSA harmonic removal")
log.info("%s/%s: removed %s from %d signals", w.test, w.profile, ds.attrs["removed_cycles"],
         len(cfg["signals"]))
