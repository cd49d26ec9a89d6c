# Physical-parameter fit (the paper's future work, docs/fit.md): identify + design ->
# fit {record} -> fit/{record}.nc, a config overlay of the fitted values, and its figure.
# A bench record (measured:) is fitted where its nonparametric FRF is coherent instead;
# with fit.data: modes, the modal table fit.modes.file is fitted (fit.records names it).
import gbpipe.config


def fit_targets():
    """Every fit, its overlay and its figure (for `all_targets`)."""
    out = []
    for record in config["fit"]["records"]:
        out += [f"{RESULTS}/fit/{record}.nc", f"{RESULTS}/fit/{record}.yaml"]
        out += figure(f"fit_{record}")
    return out


def _fit_inputs(w):
    method = config["fit"]["method"]
    if config["fit"]["data"] == "modes":     # a modal table: no identification needed
        return {"modes": config["fit"]["modes"]["file"]}
    if not gbpipe.config.simulated(config):
        return {"identified": f"{RESULTS}/identify/measured/{w.record}_{method}.nc"}
    # the predicted identifiable band of each pairing (one design job for every record)
    return {"identified": f"{RESULTS}/identify/{w.record}_{method}.nc",
            "design": f"{RESULTS}/design/{w.record}.nc"}


def _fit_pairings():
    # the fitted pairings with the bench model's signal names (fit.signals); a mapped
    # set-point (reference) stays a record signal: it says which estimator fit.data:
    # nonparametric sees
    return [{"name": p["name"],
             **{k: [gbpipe.config.model_signal(config, s) for s in p[k]]
                for k in ("inputs", "outputs")},
             **({"reference": p["reference"]} if "reference" in p else {})}
            for p in config["identify"]["pairings"] if p["name"] in config["fit"]["pairings"]]


def _fit_prior():
    # the bench the fit starts from: the config with fit.start merged (validated at load)
    prior = gbpipe.config.fit_prior(config) if config["fit"]["start"] else config
    # the model sections: a described drivetrain, else the paper's gearbox + bench
    return {k: prior[k] for k in ("gearbox", "bench", "drivetrain") if prior.get(k)}


#: What rule `fit` fits, by fit.data (its message; no param, which would be a rerun trigger)
_FIT_DATA = {"frf": "the identified FRFs", "nonparametric": "the Welch FRF estimates",
             "modes": "the modal table"}


rule fit:
    message:
        f"Fit {{params.n_free}} physical parameters to {_FIT_DATA[config['fit']['data']]} of "
        "{wildcards.record}"
    wildcard_constraints:
        record="|".join(config["fit"]["records"]) or "no_fit_records",
    input:
        unpack(_fit_inputs),
        code=code("fit.py"),
    params:
        cfg={"seed": config["seed"], "fit": config["fit"], "pairings": _fit_pairings(),
             "segment": config["identify"]["nonparametric"]["segment"]},
        prior=_fit_prior(),
        n_free=len(config["fit"]["free"]),
    output:
        nc=f"{RESULTS}/fit/{{record}}.nc",
        overlay=f"{RESULTS}/fit/{{record}}.yaml",
    log:
        f"{RESULTS}/logs/fit/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/fit/{{record}}.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("fit")
    resources:
        **DECLARED.resources("fit"),
    script:
        "../scripts/fit.py"


rule figures_fit:
    message:
        "Fit figure of {wildcards.record}: data with bounds, prior and fitted model, "
        "parameter table"
    wildcard_constraints:
        record="|".join(config["fit"]["records"]) or "no_fit_records",
    input:
        nc=rules.fit.output.nc,
        code=code("figures_fit.py"),
    params:
        formats=FIGURE_FORMATS,
    output:
        # the report's caption is a template (Snakemake does not expand wildcards in a
        # caption path); the run's numbers are in the caption file the rule writes
        **image_outputs("fig_fit", f"{RESULTS}/figures/fig_fit_{{record}}",
                        "../report/fig_fit.rst", "Physical fit"),
        fig_fit_caption=f"{RESULTS}/report/fig_fit_{{record}}.rst",
    log:
        f"{RESULTS}/logs/figures_fit/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_fit/{{record}}.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("figures_fit")
    resources:
        **DECLARED.resources("figures_fit"),
    script:
        "../scripts/figures_fit.py"
