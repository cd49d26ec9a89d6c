"""Rule `removal_tests`: one harmonic-removal method on the measured-like signals of a test
record, for the identification version named after it."""

from fractions import Fraction

from gbpipe import io
from gbpipe.harmonics import method_params, method_residuals

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, w = snakemake.params, snakemake.wildcards
families = {k: [Fraction(o) for o in v] for k, v in p.families.items()}
ds = method_residuals(io.read(snakemake.input.record), p.signals, w.method,
                      method_params({w.method: p.method_cfg}, w.method, families), families,
                      p.keep_below)
io.write(ds, snakemake.output.nc, sources=snakemake.input, stage="removal_tests",
         config=dict(p), wildcards=dict(w.items()),
         title=f"Measured-like {w.test} ({w.profile}) after {w.method} harmonic removal")
log.info("%s (%s): removed %s by %s from %d signals", w.test, w.profile, list(families),
         w.method, len(p.signals))
