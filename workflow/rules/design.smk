# Design step of identification (issue 14): before identification runs, per test the
# predicted output SNR, coherence, FRF error and identifiable band of every pairing, from
# the bench model, the test's set-points and the noise spectra (docs/design.md).


def design_tests():
    """Tests the design step predicts: the identified ramp tests and the designed ones."""
    return (list(config["identify"]["tests"])
            + [d["name"] for d in config["campaign"]["designed"]])


def design_targets():
    """Every design file and the design figure (not yet in `all_targets`)."""
    stem = f"{RESULTS}/figures/fig_design"
    return (expand(f"{RESULTS}/design/{{test}}_{{profile}}.nc", test=design_tests(),
                   profile=config["identify"]["profiles"])
            + [f"{stem}.png", f"{stem}.pdf", f"{RESULTS}/report/fig_design.rst"])


rule design:
    message:
        "Predicted identifiable band of every pairing for {wildcards.test} "
        "({wildcards.profile}), before identification"
    wildcard_constraints:
        test="|".join(design_tests()),
    input:
        code=code("design.py"),
    params:
        # the bench (model), the set-points (campaign), the noise spectra, and the
        # identification that is predicted
        cfg={**{k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise")},
             "identify": {k: config["identify"][k] for k in (
                 "pairings", "frf", "sample_rate", "order", "max_order", "tolerance_db")}},
    output:
        nc=f"{RESULTS}/design/{{test}}_{{profile}}.nc",
    log:
        f"{RESULTS}/logs/design/{{test}}_{{profile}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/design/{{test}}_{{profile}}.tsv"
    script:
        "../scripts/design.py"


rule figures_design:
    message:
        "Design figure: predicted band per pairing and test beside the achieved band"
    input:
        designs=expand(f"{RESULTS}/design/{{test}}_{{profile}}.nc", test=design_tests(),
                       profile=config["figures"]["test_profile"]),
        # achieved bands of the identified ramp tests of the same profile
        models=expand(f"{RESULTS}/identify/{{test}}_{{profile}}_{{method}}.nc",
                      test=config["identify"]["tests"],
                      profile=config["figures"]["test_profile"],
                      method=config["identify"]["methods"]),
        code=code("figures_design.py"),
    params:
        versions=config["identify"]["versions"],
    output:
        **figure_outputs("design", "Identification", name="fig_design"),
    log:
        f"{RESULTS}/logs/figures_design.log",
    script:
        "../scripts/figures_design.py"
