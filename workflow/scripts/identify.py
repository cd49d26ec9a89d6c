"""Rule `identify`: every pairing x data version of one test x profile, one method."""

from gbpipe import io
from gbpipe.identify import identify_record

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg, i = snakemake.wildcards, snakemake.params.cfg, snakemake.input
removed = {"tsa": (io.read(i.tsa_record), io.read(i.tsa_validation))}
# rules.identify lists, per removal version in order, its record then its validation record
paths = list(i.removed)
for k, version in enumerate(snakemake.params.removal_versions):
    removed[version] = (io.read(paths[2 * k]), io.read(paths[2 * k + 1]))
ds = identify_record(cfg, io.read(i.record), io.read(i.validation), io.read(i.truth), w.method,
                     removed)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="identify", config=cfg,
         wildcards={"test": w.test, "profile": w.profile, "method": w.method},
         title=f"{w.method} models of {w.test} ({w.profile}) vs the true bench model")
