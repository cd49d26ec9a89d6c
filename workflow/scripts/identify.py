"""Rule `identify`: every pairing x data version of one test x profile, one method."""

from gbpipe import io
from gbpipe.identify import identify_record

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg, i = snakemake.wildcards, snakemake.params.cfg, snakemake.input
removed = {"tsa": (io.read(i.tsa_record), io.read(i.tsa_validation))}
# rules.identify lists each removal version's record, then its validation record
pairs = [io.read(p) for p in i.removed]
for rec, partner in zip(pairs[::2], pairs[1::2], strict=True):
    removed[rec.attrs["method"]] = (rec, partner)
ds = identify_record(cfg, io.read(i.record), io.read(i.validation), io.read(i.truth), w.method,
                     removed)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="identify", config=cfg,
         wildcards={"test": w.test, "profile": w.profile, "method": w.method},
         title=f"{w.method} models of {w.test} ({w.profile}) vs the true bench model")
