"""Rule `identify`: every pairing x data version of one test x profile, every method."""

from gbpipe import io
from gbpipe.identify import identify_methods

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
w, cfg, i = snakemake.wildcards, snakemake.params.cfg, snakemake.input
methods = cfg["identify"]["methods"]
# a drivetrain's campaign has no TSA records (rules.identify)
removed = {"tsa": (io.read(i.tsa_record), io.read(i.tsa_validation))} if i.tsa_record else {}
# rules.identify lists, per removal version in order, its record then its validation record
paths = list(i.removed)
for k, version in enumerate(snakemake.params.removal_versions):
    removed[version] = (io.read(paths[2 * k]), io.read(paths[2 * k + 1]))
models = identify_methods(cfg, io.read(i.record), io.read(i.validation), io.read(i.truth),
                          methods, removed)
# every method is fitted before any file is written: a failed method leaves no output
for method, path in zip(methods, snakemake.output.nc, strict=True):
    io.write(models[method], path, sources=snakemake.input, stage="identify", config=cfg,
             wildcards={"test": w.test, "profile": w.profile, "method": method},
             title=f"{method} models of {w.test} ({w.profile}) vs the true bench model")
