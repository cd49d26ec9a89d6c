# The modes of bench records, chosen by the data (docs/modal.md): per record, the
# stabilization diagrams of every pairing (subspace and LSCF), clusters labelled mode,
# harmonic or spurious with their evidence, the model order the identify stage uses; a
# table per record and one per group of repeats, a figure per pairing.
# Included after measured.smk (MEASURED, SPECS, `record` wildcard constraint).


def _modes_cfg():
    # the config slice of the diagrams: conditioning, windows, reference, criteria
    keys = ("pairings", "sample_rate", "lowpass", "past", "future", "zeta_max",
            "nonparametric", "frf", "stabilization")
    return {"campaign": {"settle": config["campaign"]["settle"]}, "seed": config["seed"],
            "identify": {k: config["identify"][k] for k in keys}}


def _pairing_names():
    return [p["name"] for p in config["identify"]["pairings"]]


def modes_targets():
    """Final targets of the modes of bench records (for `measured_targets`)."""
    targets = expand(f"{RESULTS}/modes/measured/{{record}}.nc", record=MEASURED)
    if MEASURED:
        targets += [f"{RESULTS}/tables/modes_measured.csv",
                    f"{RESULTS}/tables/modes_measured_groups.csv"]
    for r in MEASURED:
        for p in _pairing_names():
            targets += figure(f"modes_{r}_{p}")
    return targets


rule modes_measured:
    message:
        "Modes of bench record {wildcards.record}: stabilization diagrams of every pairing, "
        "order lines labelled"
    input:
        record=rules.measured.output.record,
        code=code("modes_measured.py"),
    params:
        cfg=_modes_cfg(),
        orders=lambda w: list(SPECS[w.record].orders),
        # measured.<record>.signals.<name>.shaft_order: speeds that place the order lines
        speeds=lambda w: SPECS[w.record].speeds,
    output:
        nc=f"{RESULTS}/modes/measured/{{record}}.nc",
    log:
        f"{RESULTS}/logs/modes/measured/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/modes_measured/{{record}}.tsv"
    threads: DECLARED.threads("modes_measured")
    resources:
        **DECLARED.resources("modes_measured"),
    script:
        "../scripts/modes_measured.py"


rule modes_table_measured:
    message:
        "Tables: the modes, order lines and noise poles of every bench record x pairing x "
        "method, and per group of repeats"
    input:
        modes=expand(f"{RESULTS}/modes/measured/{{record}}.nc", record=MEASURED),
        code=code("modes_table.py"),
    params:
        groups=GROUPS,
        tolerance=config["identify"]["stabilization"]["frequency_tolerance"],
    output:
        table=f"{RESULTS}/tables/modes_measured.csv",
        groups=f"{RESULTS}/tables/modes_measured_groups.csv",
    log:
        f"{RESULTS}/logs/modes_table_measured.log",
    benchmark:
        f"{RESULTS}/benchmarks/modes_table_measured.tsv"
    threads: DECLARED.threads("modes_table_measured")
    resources:
        **DECLARED.resources("modes_table_measured"),
    script:
        "../scripts/modes_table.py"


def _modes_figure_outputs(pairings):
    out = {}
    for p in pairings:
        # the caption is a template: Snakemake does not expand wildcards in a caption path
        out.update(image_outputs(p, f"{RESULTS}/figures/fig_modes_{{record}}_{p}",
                                 "../report/fig_modes.rst", "Bench records"))
        out[f"{p}_caption"] = f"{RESULTS}/report/fig_modes_{{record}}_{p}.rst"
    return out


rule figures_modes:
    message:
        "Figure: stabilization diagrams of bench record {wildcards.record}"
    input:
        modes=rules.modes_measured.output.nc,
        code=code("figures_modes.py"),
    params:
        pairings=_pairing_names(),
        formats=FIGURE_FORMATS,
    output:
        **_modes_figure_outputs(_pairing_names()),
    log:
        f"{RESULTS}/logs/figures_modes/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_modes/{{record}}.tsv"
    threads: DECLARED.threads("figures_modes")
    resources:
        **DECLARED.resources("figures_modes"),
    script:
        "../scripts/figures_modes.py"
