"""Rule `fit`: the physical parameters of the bench fitted to one record's identified FRFs
(or to a modal table, fit.data: modes), with 95 % intervals, what the data cannot
separate, a chi-square test of the fit against the data's bounds, and a ready config
overlay of the fitted values (docs/fit.md)."""

import yaml

from gbpipe import io
from gbpipe.fit import fit_record

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i, out = snakemake.params, snakemake.input, snakemake.output
fit, record = p.cfg["fit"], snakemake.wildcards.record
if fit["data"] == "modes":
    res, ds = fit_record(p.cfg, p.prior, modes_file=i.modes)
else:  # a simulated record has its design step's predicted band; a bench record has none
    res, ds = fit_record(p.cfg, p.prior, identified=io.read(i.identified),
                         design=io.read(i.design) if "design" in i.keys() else None)
io.write(ds, out.nc, sources=i, stage=snakemake.rule, config=dict(p),
         wildcards={"record": record},
         title=f"Physical parameters fitted to the {fit['data']} of {record}")
with io.atomic_path(out.overlay) as tmp:
    tmp.write_text(f"# gbpipe fit of {record} ({fit['data']}): the fitted free parameters "
                   f"as a config overlay\n# (snakemake --configfile {out.overlay}); "
                   f"intervals and goodness ({res.goodness.status}): {out.nc}\n"
                   + yaml.safe_dump(res.overlay(), sort_keys=False))
