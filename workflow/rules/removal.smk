# Harmonic removal beyond TSA: every method of `removal.methods` on the sweep, scored by
# the exact separation metric against the random-only sweep (the same simulation with the
# angle-locked excitation off), side by side in tables/removal.csv and one trade-off
# figure; and on the tests (scored against the random-only tests), as identification
# versions named after the method.
REMOVAL_METHODS = config["removal"]["methods"]
# what the families removed derive from (gbpipe.harmonics.excitation_families, test_families):
# the gear excitation and the motors' pulsating torque of the record (the sweep has its own
# noise section)
FAMILIES_CFG = {"gearbox": {"stages": config["gearbox"]["stages"]},
                "excitation": config["excitation"], "noise": config["noise"]}
SWEEP_FAMILIES_CFG = {**FAMILIES_CFG, "noise": config["sweep"]["noise"]}


def removal_targets():
    """Final targets of the removal comparison (for `all_targets`)."""
    if not REMOVAL_METHODS:
        return []
    return ([f"{RESULTS}/tables/removal.csv"] + figure("removal_tradeoff")
            + figure("removal_crossing"))


def _removal_test_jobs():
    idc = config["identify"]
    return expand(f"{RESULTS}/removal/tests/{{m}}/{{t}}_{{p}}.nc", m=REMOVAL_VERSIONS,
                  t=idc["tests"], p=idc["profiles"])


rule removal:
    message:
        "Harmonic removal by {params.methods} on the sweep, each scored against the "
        "random-only sweep"
    input:
        sweep=rules.sweep.output.nc,
        random=rules.sweep.output.random,
        bench=f"{RESULTS}/model/bench.nc",
        code=code("removal.py"),
    params:
        # one job runs every method on the sweep and its twin read once (1.2 M samples
        # each); the settings of each method, in the order of removal.methods
        method_cfg={m: config["removal"][m] for m in REMOVAL_METHODS},
        families_cfg=SWEEP_FAMILIES_CFG,
        spectra=config["spectra"],
        methods=", ".join(REMOVAL_METHODS),
    output:
        nc=expand(f"{RESULTS}/removal/{{method}}.nc", method=REMOVAL_METHODS),
    log:
        f"{RESULTS}/logs/removal.log",
    benchmark:
        f"{RESULTS}/benchmarks/removal.tsv"
    priority: SWEEP_PATH
    threads: DECLARED.threads("removal")
    resources:
        **DECLARED.resources("removal"),
    script:
        "../scripts/removal.py"


rule removal_table:
    message:
        "Table: attenuation and broadband distortion of every removal method x family x rpm "
        "bin x band"
    input:
        methods=expand(f"{RESULTS}/removal/{{m}}.nc", m=REMOVAL_METHODS),
        tests=_removal_test_jobs(),
        code=code("removal_table.py"),
    output:
        table=f"{RESULTS}/tables/removal.csv",
    log:
        f"{RESULTS}/logs/removal_table.log",
    benchmark:
        f"{RESULTS}/benchmarks/removal_table.tsv"
    threads: DECLARED.threads("removal_table")
    resources:
        **DECLARED.resources("removal_table"),
    script:
        "../scripts/removal_table.py"


rule figures_removal:
    message:
        "Figure: attenuation against broadband distortion of every removal method"
    input:
        methods=expand(f"{RESULTS}/removal/{{m}}.nc", m=REMOVAL_METHODS),
        code=code("figures_removal.py"),
    params:
        methods=REMOVAL_METHODS,
        formats=FIGURE_FORMATS,
    output:
        **figure_outputs("removal_tradeoff", "Harmonic removal", name="removal_tradeoff"),
    log:
        f"{RESULTS}/logs/figures_removal.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_removal.tsv"
    threads: DECLARED.threads("figures_removal")
    resources:
        **DECLARED.resources("figures_removal"),
    script:
        "../scripts/figures_removal.py"


rule figures_removal_crossing:
    message:
        "Figure: the mode band at the worst order/mode crossing, in the record, its "
        "random-only twin and every method's residual"
    input:
        methods=expand(f"{RESULTS}/removal/{{m}}.nc", m=REMOVAL_METHODS),
        sweep=rules.sweep.output.nc,
        random=rules.sweep.output.random,
        code=code("figures_removal_crossing.py"),
    params:
        methods=REMOVAL_METHODS,
        signal=config["spectra"]["signal"],
        formats=FIGURE_FORMATS,
    output:
        **figure_outputs("removal_crossing", "Harmonic removal", name="removal_crossing"),
    log:
        f"{RESULTS}/logs/figures_removal_crossing.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_removal_crossing.tsv"
    threads: DECLARED.threads("figures_removal_crossing")
    resources:
        **DECLARED.resources("figures_removal_crossing"),
    script:
        "../scripts/figures_removal_crossing.py"


rule removal_tests:
    message:
        "Harmonic removal (TSA of {params.cycles}{params.methods}) on the measured-like "
        "records identified and their validation records ({params.n_records}), for "
        "identification"
    input:
        record=[f"{RESULTS}/simulate/{t}_{p}.nc" for t, p in REMOVAL_RECORDS],
        # the removal versions are scored against the random-only twin (TSA is not)
        random=[f"{RESULTS}/simulate/random/{t}_{p}.nc" for t, p in CAMPAIGN_TWINS],
        bench=f"{RESULTS}/model/bench.nc" if REMOVAL_VERSIONS else [],
        code=code("removal_tests.py"),
    params:
        records=REMOVAL_RECORDS,
        n_records=len(REMOVAL_RECORDS),
        tsa_cfg={"tsa": {k: config["tsa"][k] for k in ("n_cycles", "tests", "unbiased")},
                 "stages": config["gearbox"]["stages"]},
        method_cfg={m: config["removal"][m] for m in REMOVAL_VERSIONS},
        families_cfg={**FAMILIES_CFG, "removal": {"tests": config["removal"]["tests"]}},
        signals=_id_signals(),
        keep_below=config["identify"]["tsa_keep_below"],
        spectra=config["spectra"],
        cycles="+".join(config["tsa"]["tests"]),
        methods="".join(f", {m}" for m in REMOVAL_VERSIONS),
    output:
        # one job for every record (each read once, and with its random-only twin the
        # harmonic part formed once): a record takes ~2 s here, while a job of its own
        # costs ~1 s more to start (Python and its imports). Per record in the order of
        # params.records: the tsa version, and one file per method of REMOVAL_VERSIONS
        tsa=[f"{RESULTS}/tsa/tests/{t}_{p}.nc" for t, p in REMOVAL_RECORDS],
        nc=[f"{RESULTS}/removal/tests/{m}/{t}_{p}.nc" for t, p in REMOVAL_RECORDS
            for m in REMOVAL_VERSIONS],
    log:
        f"{RESULTS}/logs/removal_tests.log",
    benchmark:
        f"{RESULTS}/benchmarks/removal_tests.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("removal_tests")
    resources:
        **DECLARED.resources("removal_tests"),
    script:
        "../scripts/removal_tests.py"
