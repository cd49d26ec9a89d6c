# Bench records (config `measured:`): files -> results/measured/{record}.nc -> spectra,
# TSA and identification against the nonparametric FRF of the data (no truth exists).
# When `measured:` is not empty, these are the workflow's targets instead of the simulated
# campaign (common.smk, all_targets).
import gbpipe.config

MEASURED = list(config["measured"])
# the records' mappings, parsed (and checked) once at load
SPECS = gbpipe.config.measured_specs(config)
# repeats of one test (`group:`), identified pooled besides each record alone
GROUPS = {}
for _name, _spec in SPECS.items():
    if _spec.group is not None:
        GROUPS.setdefault(_spec.group, []).append(_name)


def _bench_files(w):
    # the record's source files: a changed file reruns the record
    return [f.path for f in SPECS[w.record].files.values()]


def _has_tacho(record):
    return any(s.quantity == "tacho" for s in SPECS[record].signals.values())


def _measured_identify_jobs():
    # every record alone, and every group of repeats pooled
    return expand(f"{RESULTS}/identify/measured/{{record}}_{{method}}.nc",
                  record=MEASURED + list(GROUPS), method=config["identify"]["methods"])


def _unit_records(w):
    # the records an identify_measured job pools: a group's repeats, or the record itself
    return GROUPS.get(w.record, [w.record])


def _stabilization(w):
    # identify.order: stabilization takes the orders from the record's stabilization
    # diagram (rule modes_measured; a group: its first record's)
    if config["identify"]["order"] != "stabilization":
        return []
    return [f"{RESULTS}/modes/measured/{_unit_records(w)[0]}.nc"]


def measured_targets():
    """Final targets of the bench records (for `all_targets`)."""
    targets = expand(f"{RESULTS}/measured/{{record}}.nc", record=MEASURED)
    targets += [f"{RESULTS}/spectra/measured/{r}.nc" for r in MEASURED if _has_tacho(r)]
    targets += _measured_identify_jobs()
    targets.append(f"{RESULTS}/tables/identification_measured.csv")
    for r in MEASURED:
        targets += figure(f"measured_{r}")
    # the modes the data choose, table and stabilization figures (modes.smk)
    return targets + modes_targets()


wildcard_constraints:
    record="|".join(MEASURED + list(GROUPS)) if MEASURED else "no_measured_record",


rule measured:
    message:
        "Read bench record {wildcards.record}: files -> checked, SI units, common time grid"
    input:
        files=_bench_files,
        code=code("measured.py"),
    params:
        spec=lambda w: config["measured"][w.record],
        min_duration=gbpipe.config.min_duration(config) if MEASURED else 0.0,
    output:
        record=f"{RESULTS}/measured/{{record}}.nc",
    log:
        f"{RESULTS}/logs/measured/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/measured/{{record}}.tsv"
    threads: DECLARED.threads("measured")
    resources:
        **DECLARED.resources("measured"),
    script:
        "../scripts/measured.py"


rule spectra_measured:
    message:
        "Power and order spectra vs rpm of bench record {wildcards.record}"
    input:
        record=rules.measured.output.record,
        code=code("spectra.py"),
    params:
        spectra=config["spectra"],
        what=lambda w: f"bench record {w.record}",
    output:
        nc=f"{RESULTS}/spectra/measured/{{record}}.nc",
    log:
        f"{RESULTS}/logs/spectra/measured/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/spectra_measured/{{record}}.tsv"
    threads: DECLARED.threads("spectra_measured")
    resources:
        **DECLARED.resources("spectra_measured"),
    script:
        "../scripts/spectra.py"


rule tsa_measured:
    message:
        "Harmonic removal (TSA of {params.cycles}) on bench record {wildcards.record}"
    input:
        record=rules.measured.output.record,
        code=code("tsa_measured.py"),
    params:
        cfg=lambda w: {"tsa": {k: config["tsa"][k] for k in ("n_cycles", "tests", "unbiased")},
                       "stages": config["gearbox"]["stages"], "signals": _id_signals(),
                       "keep_below": config["identify"]["tsa_keep_below"]},
        cycles=lambda w: "+".join(config["tsa"]["tests"]),
        what=lambda w: f"bench record {w.record}",
    output:
        nc=f"{RESULTS}/tsa/measured/{{record}}.nc",
    log:
        f"{RESULTS}/logs/tsa/measured/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/tsa_measured/{{record}}.tsv"
    threads: DECLARED.threads("tsa_measured")
    resources:
        **DECLARED.resources("tsa_measured"),
    script:
        "../scripts/tsa_measured.py"


rule identify_measured:
    message:
        "Identify {wildcards.method} on bench record (or group of repeats) "
        "{wildcards.record}: every pairing x data version vs the nonparametric FRF of the data"
    wildcard_constraints:
        method="pbsid|moesp|n4sid",
    input:
        # one record, or every repeat of a group (pooled)
        records=lambda w: [f"{RESULTS}/measured/{r}.nc" for r in _unit_records(w)],
        tsa_records=lambda w: ([f"{RESULTS}/tsa/measured/{r}.nc" for r in _unit_records(w)]
                               if "tsa" in config["identify"]["versions"] else []),
        modes=_stabilization,
        code=code("identify_measured.py"),
    params:
        # tests, profiles and best.* are of the simulated campaign: not this job's
        cfg=lambda w: {"campaign": {"settle": config["campaign"]["settle"]},
                       "identify": {k: v for k, v in config["identify"].items()
                                    if k not in ("tests", "profiles", "best")}},
        # measured.<record>.validation: the held-out window [s] per record (None: chosen)
        windows=lambda w: [SPECS[r].validation for r in _unit_records(w)],
        group=lambda w: w.record if w.record in GROUPS else "",
        # measured.<record>.orders: no model is judged on these order lines (a group:
        # every repeat's)
        line_orders=lambda w: sorted({k for r in _unit_records(w) for k in SPECS[r].orders}),
    output:
        nc=f"{RESULTS}/identify/measured/{{record}}_{{method}}.nc",
    log:
        f"{RESULTS}/logs/identify/measured/{{record}}_{{method}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/identify_measured/{{record}}_{{method}}.tsv"
    threads: DECLARED.threads("identify_measured")
    resources:
        **DECLARED.resources("identify_measured"),
    script:
        "../scripts/identify_measured.py"


rule identification_table_measured:
    message:
        "Table: match bandwidth and fit of every bench record x method x pairing x version"
    input:
        models=_measured_identify_jobs(),
        code=code("identification_table.py"),
    output:
        table=f"{RESULTS}/tables/identification_measured.csv",
    log:
        f"{RESULTS}/logs/identification_table_measured.log",
    benchmark:
        f"{RESULTS}/benchmarks/identification_table_measured.tsv"
    threads: DECLARED.threads("identification_table_measured")
    resources:
        **DECLARED.resources("identification_table_measured"),
    script:
        "../scripts/identification_table.py"


rule figures_measured:
    message:
        "Figure: identified models of bench record {wildcards.record} against its data"
    input:
        models=expand(f"{RESULTS}/identify/measured/{{{{record}}}}_{{method}}.nc",
                      method=config["identify"]["methods"]),
        code=code("figures_measured.py"),
    params:
        coherence_min=config["identify"]["nonparametric"]["coherence_min"],
        formats=FIGURE_FORMATS,
    output:
        # the caption is a template: Snakemake does not expand wildcards in a caption path
        **image_outputs("fig", f"{RESULTS}/figures/fig_measured_{{record}}",
                        "../report/fig_measured.rst", "Bench records"),
        caption=f"{RESULTS}/report/fig_measured_{{record}}.rst",
    log:
        f"{RESULTS}/logs/figures_measured/{{record}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_measured/{{record}}.tsv"
    threads: DECLARED.threads("figures_measured")
    resources:
        **DECLARED.resources("figures_measured"),
    script:
        "../scripts/figures_measured.py"
