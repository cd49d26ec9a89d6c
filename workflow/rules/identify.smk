# Identification stage (paper section 3, Fig 6, and its future work: identification after
# harmonic removal). model (truth.nc) + campaign + removal_tests -> identify
# {test}_{profile}_{method} -> table + figures. REMOVAL_VERSIONS and _partner: common.smk.


def _id_signals():
    # every signal a pairing uses (the TSA stage removes harmonics from exactly these)
    names = []
    for p in config["identify"]["pairings"]:
        names += [n for n in p["inputs"] + p["outputs"] if n not in names]
    return names


def _id_jobs():
    idc = config["identify"]
    return expand(f"{RESULTS}/identify/{{test}}_{{profile}}_{{method}}.nc",
                  test=idc["tests"], profile=idc["profiles"], method=idc["methods"])


_BANDWIDTH_STEM = f"{RESULTS}/figures/identification_bandwidth"
_BANDWIDTH_CAPTION = f"{RESULTS}/report/identification_bandwidth.rst"


def identify_targets():
    """Final targets of the identification stage (for `all_targets`)."""
    return (_id_jobs() + [f"{RESULTS}/tables/identification.csv"] + figure(6)
            + figure_files(_BANDWIDTH_STEM) + [_BANDWIDTH_CAPTION])


rule identify:
    message:
        "Identify {wildcards.test} ({wildcards.profile}) with {params.methods}: every "
        "pairing x data version vs the true model"
    input:
        record=f"{RESULTS}/simulate/{{test}}_{{profile}}.nc",
        validation=lambda w: f"{RESULTS}/simulate/{_partner(w.test)}_{w.profile}.nc",
        # (a drivetrain's records have no TSA version: identify.versions clean, raw)
        tsa_record=[] if DRIVETRAIN else f"{RESULTS}/tsa/tests/{{test}}_{{profile}}.nc",
        tsa_validation=lambda w: ([] if DRIVETRAIN else
                                  f"{RESULTS}/tsa/tests/{_partner(w.test)}_{w.profile}.nc"),
        # per removal version: the record after it, then the validation record after it
        removed=lambda w: [f"{RESULTS}/removal/tests/{m}/{t}_{w.profile}.nc"
                           for m in REMOVAL_VERSIONS
                           for t in (w.test, _partner(w.test))],
        truth=rules.model.output.truth,
        code=code("identify.py"),
    params:
        # the truth comes from truth.nc (the model stage): no gearbox or bench here
        cfg=lambda w: {"campaign": {"settle": config["campaign"]["settle"]},
                       "identify": config["identify"]},
        removal_versions=REMOVAL_VERSIONS,
        methods=lambda w: ", ".join(config["identify"]["methods"]),
    output:
        # one job per record fits every method on the same conditioned (decimated) data;
        # one file per method, in the order of identify.methods
        nc=expand(f"{RESULTS}/identify/{{{{test}}}}_{{{{profile}}}}_{{method}}.nc",
                  method=config["identify"]["methods"]),
    log:
        f"{RESULTS}/logs/identify/{{test}}_{{profile}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/identify/{{test}}_{{profile}}.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("identify")
    resources:
        **DECLARED.resources("identify"),
    script:
        "../scripts/identify.py"


rule identification_table:
    message:
        "Table: match bandwidth, fit and modes of every variant x method x pairing x version"
    input:
        models=_id_jobs(),
        # the predicted bands (design step), written before identification ran
        designs=rules.design.output.nc,
        code=code("identification_table.py"),
    output:
        table=f"{RESULTS}/tables/identification.csv",
    log:
        f"{RESULTS}/logs/identification_table.log",
    benchmark:
        f"{RESULTS}/benchmarks/identification_table.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("identification_table")
    resources:
        **DECLARED.resources("identification_table"),
    script:
        "../scripts/identification_table.py"


rule figures_identify:
    message:
        "Figure 6 (identified vs true Bode magnitude, best case) and match bandwidth figure"
    input:
        models=_id_jobs(),
        table=rules.identification_table.output.table,
        code=code("figures_identify.py"),
    params:
        best=lambda w: config["identify"]["best"],
        formats=FIGURE_FORMATS,
    output:
        **figure_outputs(6, "Identification"),
        **image_outputs("bandwidth", _BANDWIDTH_STEM, f"../../{_BANDWIDTH_CAPTION}",
                        "Identification"),
        bandwidth_caption=_BANDWIDTH_CAPTION,
    log:
        f"{RESULTS}/logs/figures_identify.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_identify.tsv"
    threads: DECLARED.threads("figures_identify")
    resources:
        **DECLARED.resources("figures_identify"),
    script:
        "../scripts/figures_identify.py"
