# Design step of identification (issue 14): before identification runs, per test the
# predicted output SNR, coherence, FRF error and identifiable band of every pairing, from
# the bench model, the test's set-points and the noise spectra (docs/design.md).


def design_tests():
    """Tests the design step predicts: the identified tests and every designed test."""
    names = list(config["identify"]["tests"])
    return names + [d["name"] for d in config["campaign"]["designed"] if d["name"] not in names]


def _design_files():
    return expand(f"{RESULTS}/design/{{test}}_{{profile}}.nc", test=design_tests(),
                  profile=config["identify"]["profiles"])


def design_targets():
    """Every design file and the design figure (for `all_targets`)."""
    return _design_files() + figure("design")


rule design:
    message:
        "Predicted identifiable band of every pairing for every test and profile, before "
        "identification"
    input:
        code=code("design.py"),
    params:
        # the bench (model), the set-points (campaign), the noise spectra and the gear
        # excitation, what each data version removes, and the identification predicted
        cfg={**{k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                       "excitation")}, **DRIVETRAIN,
             "tsa": {"tests": config["tsa"]["tests"]},
             "removal": {"tests": config["removal"]["tests"]},
             "identify": {k: config["identify"][k] for k in (
                 "pairings", "versions", "frf", "sample_rate", "order", "max_order",
                 "tolerance_db")}},
        records=[(t, p) for t in design_tests() for p in config["identify"]["profiles"]],
    output:
        # one job: the bench and the true models are built once for every record
        nc=_design_files(),
    log:
        f"{RESULTS}/logs/design.log",
    benchmark:
        f"{RESULTS}/benchmarks/design.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("design")
    resources:
        **DECLARED.resources("design"),
    script:
        "../scripts/design.py"


rule figures_design:
    message:
        "Design figure: predicted band per pairing and test beside the achieved band"
    input:
        # every predicted band, and the achieved bands of every identified record
        designs=rules.design.output.nc,
        models=lambda w: _id_jobs(),  # identify.smk is included after this file
        code=code("figures_design.py"),
    params:
        versions=config["identify"]["versions"],
        formats=FIGURE_FORMATS,
    output:
        **figure_outputs("design", "Identification", name="fig_design"),
    log:
        f"{RESULTS}/logs/figures_design.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_design.tsv"
    threads: DECLARED.threads("figures_design")
    resources:
        **DECLARED.resources("figures_design"),
    script:
        "../scripts/figures_design.py"
