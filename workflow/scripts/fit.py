"""Rule `fit`: the physical parameters of the bench fitted to one record's identified FRFs
(or to a modal table, fit.data: modes), with 95 % intervals, what the data cannot
separate, a chi-square test of the fit against the data's bounds, and a ready config
overlay of the fitted values (docs/fit.md)."""

import yaml

from gbpipe import io, model

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
p, i, out = snakemake.params, snakemake.input, snakemake.output
fit = p.cfg["fit"]
pairings = [model.Pairing.from_config(q) for q in p.cfg["pairings"]]
common = {"bounds": fit["bounds"], "factor": fit["factor"], "n_starts": fit["starts"],
          "seed": p.cfg["seed"], "search": fit["search"], "alpha": fit["alpha"],
          "accuracy": fit["accuracy"]}
if fit["data"] == "modes":
    m = fit["modes"]
    system = next((q for q in pairings if q.name == m["system"]), None)
    data = model.read_modes_table(i.modes, m["pairing"], m["method"], system,
                                  tuple(m["band"]))
    log.info("fitting %s from the prior (fit.start) to %d modes of %s (%s)",
             ", ".join(fit["free"]), data.frequency_hz.size, i.modes, m["system"])
    res = model.fit_parameters(p.prior, data, fit["free"], **common)
else:
    identified = io.read(i.identified)
    # a simulated record: the design step's predicted band of the fitted version; a bench
    # record: where its nonparametric FRF is coherent
    band = (io.read(i.design).identifiable.sel(version=fit["version"])
            if "design" in i.keys() else model.assessable_band(identified, fit["version"]))
    data = model.fit_data(identified, band, pairings, fit["version"], fit["band"],
                          fit["weight"])
    log.info("fitting %s from the prior (fit.start) to %d pairings, version %s",
             ", ".join(fit["free"]), len(data), fit["version"])
    res = model.fit_parameters(p.prior, data, fit["free"], delay=fit["delay"],
                               max_delay=fit["max_delay"], **common)
    if fit["jackknife"]:
        res = model.jackknife_intervals(res, data, fit["jackknife"], delay=fit["delay"],
                                        max_delay=fit["max_delay"])
log.info("cost %.4g at the prior, %.4g fitted, %d model evaluations (%s)\n%s",
         res.cost_prior, res.cost, res.n_evaluations, res.search, res.table())
g = res.goodness
(log.warning if g.status == "poor" else log.info)("goodness of fit: %s: %s", g.status,
                                                  g.reason)
for name, share, count in zip(g.groups, g.group_share, g.group_count_share, strict=True):
    log.info("  %s: %.1f %% of chi2 (%.1f %% of the residuals)", name, 100 * share,
             100 * count)
for k, share in enumerate(g.band_share):
    log.info("  %.4g-%.4g Hz: %.1f %% of chi2 (%.1f %% of the residuals)",
             g.band_edges[k], g.band_edges[k + 1], 100 * share, 100 * g.band_count_share[k])
if fit["data"] == "modes":
    ds = model.modal_fit_dataset(res, fit["modes"]["system"], p.prior)
else:
    ds = model.fit_dataset(res, data, p.prior, identified, fit["version"])
io.write(ds, out.nc, sources=i, stage=snakemake.rule, config=dict(p),
         wildcards={"record": snakemake.wildcards.record},
         title=f"Physical parameters fitted to the {fit['data']} of {snakemake.wildcards.record}")
with io.atomic_path(out.overlay) as tmp:
    tmp.write_text(f"# gbpipe fit of {snakemake.wildcards.record} ({fit['data']}): the fitted "
                   f"free parameters as a config overlay\n"
                   f"# (snakemake --configfile {out.overlay}); intervals and goodness "
                   f"({g.status}): {out.nc}\n" + yaml.safe_dump(res.overlay(), sort_keys=False))
if "design_rank" in ds:
    for added, rank, names in zip(ds.candidate.values, ds.design_rank.values,
                                  ds.design_identifiable.values, strict=True):
        log.info("design help: %s -> %d of %d directions determined (%s)", added, rank,
                 len(fit["free"]), names or "none")
