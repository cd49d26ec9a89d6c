# Virtual torque sensors (docs/virtual.md): a bench record (measured) and the chain, as
# configured or with its fitted overlay (fit/{record}.yaml) -> virtual/{record}.nc (the
# torques of the chosen shafts and mounts with 95 % bands, held-out sensors compared, load
# spectra) -> tables/virtual.csv and the figure per record.
import gbpipe.config

VIRTUAL = list(config["virtual"]["records"])


def virtual_targets():
    """Every virtual-sensor output, the table and the figures (for `all_targets`)."""
    if not VIRTUAL:
        return []
    out = [f"{RESULTS}/virtual/{r}.nc" for r in VIRTUAL]
    out.append(f"{RESULTS}/tables/virtual.csv")
    for r in VIRTUAL:
        out += figure(f"virtual_{r}")
    return out


def _virtual_inputs(w):
    out = {"record": f"{RESULTS}/measured/{w.record}.nc"}
    if config["virtual"]["model"] == "fitted":
        out["overlay"] = f"{RESULTS}/fit/{w.record}.yaml"
    return out


def _virtual_model():
    # the model sections the chain is built from: a described drivetrain, else the paper's
    # gearbox + bench; with a fitted model the fit's prior (fit.start merged), over which
    # the rule merges the record's overlay
    prior = (gbpipe.config.fit_prior(config) if config["virtual"]["model"] == "fitted"
             and config["fit"]["start"] else config)
    return {k: prior[k] for k in ("gearbox", "bench", "drivetrain") if prior.get(k)}


rule virtual:
    message:
        "Virtual torque sensors of {wildcards.record}: estimates with 95 % bands, held-out "
        "sensors compared, load spectra"
    wildcard_constraints:
        record="|".join(VIRTUAL) or "no_virtual_records",
    input:
        unpack(_virtual_inputs),
        code=code("virtual.py"),
    params:
        virtual=config["virtual"],
        model=_virtual_model(),
        # a record's signal names -> the chain's, where they differ (fit.signals)
        signals=config["fit"]["signals"],
    output:
        nc=f"{RESULTS}/virtual/{{record}}.nc",
    log:
        f"{RESULTS}/logs/virtual/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/virtual/{{record}}.tsv"
    threads: DECLARED.threads("virtual")
    resources:
        **DECLARED.resources("virtual"),
    script:
        "../scripts/virtual.py"


rule virtual_table:
    message:
        "Table: fit, RMS error and 95 % band coverage of every held-out sensor"
    input:
        nc=expand(f"{RESULTS}/virtual/{{record}}.nc", record=VIRTUAL),
        code=code("virtual_table.py"),
    output:
        table=f"{RESULTS}/tables/virtual.csv",
    log:
        f"{RESULTS}/logs/virtual_table.log",
    benchmark:
        f"{RESULTS}/benchmarks/virtual_table.tsv"
    threads: DECLARED.threads("virtual_table")
    resources:
        **DECLARED.resources("virtual_table"),
    script:
        "../scripts/virtual_table.py"


rule figures_virtual:
    message:
        "Virtual-sensor figure of {wildcards.record}: estimate, band, held-out measurement, "
        "load spectra"
    wildcard_constraints:
        record="|".join(VIRTUAL) or "no_virtual_records",
    input:
        nc=rules.virtual.output.nc,
        code=code("figures_virtual.py"),
    params:
        formats=FIGURE_FORMATS,
    output:
        **image_outputs("fig_virtual", f"{RESULTS}/figures/fig_virtual_{{record}}",
                        "../report/fig_virtual.rst", "Virtual sensors"),
        fig_virtual_caption=f"{RESULTS}/report/fig_virtual_{{record}}.rst",
    log:
        f"{RESULTS}/logs/figures_virtual/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_virtual/{{record}}.tsv"
    threads: DECLARED.threads("figures_virtual")
    resources:
        **DECLARED.resources("figures_virtual"),
    script:
        "../scripts/figures_virtual.py"
