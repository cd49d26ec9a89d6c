# Identification stage (paper section 3, Fig 6, and its future work: identification after
# harmonic removal). tsa_tests -> identify {test}_{profile}_{method} -> table + figures.



ID_PARTNER = {"speed_up": "speed_down", "speed_down": "speed_up",
              "torque_up": "torque_down", "torque_down": "torque_up"}


def _id_signals():
    # every signal a pairing uses (the TSA stage removes harmonics from exactly these)
    names = []
    for p in config["identify"]["pairings"]:
        names += [n for n in p["inputs"] + p["outputs"] if n not in names]
    return names


def _id_cfg():
    # config slice of `identify`: the truth needs gearbox + bench, detrending the settle time
    return {"gearbox": config["gearbox"], "bench": config["bench"],
            "campaign": {"settle": config["campaign"]["settle"]},
            "identify": config["identify"]}


def _id_jobs():
    idc = config["identify"]
    return expand(f"{RESULTS}/identify/{{test}}_{{profile}}_{{method}}.nc",
                  test=idc["tests"], profile=idc["profiles"], method=idc["methods"])


def _bandwidth_figure():
    stem = f"{RESULTS}/figures/identification_bandwidth"
    return [f"{stem}.png", f"{stem}.pdf", f"{RESULTS}/report/identification_bandwidth.rst"]


def identify_targets():
    """Final targets of the identification stage (for the lead's `all_targets`)."""
    return (_id_jobs() + [f"{RESULTS}/tables/identification.csv"] + figure(6)
            + _bandwidth_figure())


rule tsa_tests:
    message:
        "Harmonic removal (TSA of {params.cycles}) on the measured-like {wildcards.test} "
        "({wildcards.profile}) record, for identification"
    input:
        record=f"{RESULTS}/simulate/{{test}}_{{profile}}.nc",
        code=lib("identify/prepare.py", "identify/stage.py", "tsa.py", "orders.py",
                 "kinematics.py", "io.py"),
    params:
        cfg=lambda w: {"tsa": {k: config["tsa"][k] for k in ("n_cycles", "tests", "unbiased")
                               if k in config["tsa"]},
                       "stages": config["gearbox"]["stages"], "signals": _id_signals(),
                       "keep_below": config["identify"].get("tsa_keep_below", 0.5)},
        cycles=lambda w: "+".join(config["tsa"]["tests"]),
    output:
        f"{RESULTS}/tsa/tests/{{test}}_{{profile}}.nc",
    log:
        f"{RESULTS}/logs/tsa_tests/{{test}}_{{profile}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/tsa_tests/{{test}}_{{profile}}.tsv"
    resources:
        mem_mb=2000,
    script:
        "../scripts/tsa_tests.py"


rule identify:
    message:
        "Identify {wildcards.method} on {wildcards.test} ({wildcards.profile}): every pairing "
        "x data version vs the true model"
    wildcard_constraints:
        method="pbsid|moesp|n4sid",
    input:
        record=f"{RESULTS}/simulate/{{test}}_{{profile}}.nc",
        validation=lambda w: f"{RESULTS}/simulate/{ID_PARTNER[w.test]}_{w.profile}.nc",
        tsa_record=f"{RESULTS}/tsa/tests/{{test}}_{{profile}}.nc",
        tsa_validation=lambda w: f"{RESULTS}/tsa/tests/{ID_PARTNER[w.test]}_{w.profile}.nc",
        code=lib("identify/__init__.py", "identify/prepare.py", "identify/truth.py",
                 "identify/metrics.py", "identify/stage.py", "sysid/__init__.py",
                 "sysid/_common.py", "sysid/pbsid.py", "sysid/moesp.py", "sysid/n4sid.py",
                 "sysid/result.py", "model/__init__.py", "model/statespace.py",
                 "model/drivetrain.py", "model/mechanics.py", "io.py"),
    params:
        cfg=lambda w: _id_cfg(),
    output:
        f"{RESULTS}/identify/{{test}}_{{profile}}_{{method}}.nc",
    log:
        f"{RESULTS}/logs/identify/{{test}}_{{profile}}_{{method}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/identify/{{test}}_{{profile}}_{{method}}.tsv"
    resources:
        mem_mb=2000,
    script:
        "../scripts/identify.py"


rule identification_table:
    message:
        "Table: match bandwidth, fit and modes of every variant x method x pairing x version"
    input:
        models=_id_jobs(),
        code=lib("identify/stage.py", "tables.py", "io.py"),
    output:
        f"{RESULTS}/tables/identification.csv",
    log:
        f"{RESULTS}/logs/identification_table.log",
    script:
        "../scripts/identify.py"


rule figures_identify:
    message:
        "Figure 6 (identified vs true Bode magnitude, best case) and match bandwidth figure"
    input:
        models=_id_jobs(),
        table=f"{RESULTS}/tables/identification.csv",
        code=lib("figures/identification_plots.py", "figures/style.py",
                 "figures/captions.py"),
    params:
        best=lambda w: config["identify"]["best"],
    output:
        figure_outputs(6, "Identification")
        + [report(_bandwidth_figure()[0],
                  caption=f"../../{_bandwidth_figure()[2]}", category="Identification")]
        + _bandwidth_figure()[1:],
    log:
        f"{RESULTS}/logs/figures_identify.log",
    script:
        "../scripts/figures_identify.py"
