"""Rule `fit`: the physical parameters of the bench fitted to one record's identified FRFs,
with 95 % intervals, what the data cannot separate, and a ready config overlay of the
fitted values (docs/fit.md)."""

import yaml

from gbpipe import io, model

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i, out = snakemake.params, snakemake.input, snakemake.output
fit = p.cfg["fit"]
identified = io.read(i.identified)
pairings = [model.Pairing.from_config(q) for q in p.cfg["pairings"]]
# a simulated record: the design step's predicted band of the fitted version; a bench
# record: where its nonparametric FRF is coherent
band = (io.read(i.design).identifiable.sel(version=fit["version"]) if "design" in i.keys()
        else model.assessable_band(identified, fit["version"]))
data = model.fit_data(identified, band, pairings, fit["version"], fit["band"], fit["weight"])
log.info("fitting %s from the prior (fit.start) to %d pairings, version %s",
         ", ".join(fit["free"]), len(data), fit["version"])
res = model.fit_parameters(p.prior, data, fit["free"], bounds=fit["bounds"],
                           factor=fit["factor"], n_starts=fit["starts"], seed=p.cfg["seed"],
                           delay=fit["delay"], max_delay=fit["max_delay"])
if fit["jackknife"]:
    res = model.jackknife_intervals(res, data, fit["jackknife"], delay=fit["delay"],
                                    max_delay=fit["max_delay"])
log.info("cost %.4g at the prior, %.4g fitted, %d model evaluations\n%s", res.cost_prior,
         res.cost, res.n_evaluations, res.table())
ds = model.fit_dataset(res, data, p.prior, identified, fit["version"])
io.write(ds, out.nc, sources=i, stage=snakemake.rule, config=dict(p),
         wildcards={"record": snakemake.wildcards.record},
         title=f"Physical parameters fitted to the identified FRFs of {snakemake.wildcards.record}")
with io.atomic_path(out.overlay) as tmp:
    tmp.write_text(f"# gbpipe fit of {snakemake.wildcards.record} ({fit['version']} data, "
                   f"{fit['method']}): the fitted free parameters as a config overlay\n"
                   f"# (snakemake --configfile {out.overlay}); intervals: {out.nc}\n"
                   + yaml.safe_dump(res.overlay(), sort_keys=False))
for added, rank, names in zip(ds.candidate.values, ds.design_rank.values,
                             ds.design_identifiable.values, strict=True):
    log.info("design help: %s -> %d of %d directions determined (%s)", added, rank,
             len(fit["free"]), names or "none")
