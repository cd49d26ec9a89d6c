# the test records' config slice (also that of the campaign rule, removal.smk, which
# simulates every record the workflow reads in one job; this rule makes any other record)
SIMULATE_CFG = {k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                       "excitation", "tachometer")}


rule simulate:
    message:
        "Closed-loop test {wildcards.test} ({wildcards.profile} steps), clean and measured-like"
    input:
        code=code("simulate.py"),
    params:
        cfg=SIMULATE_CFG,
        records=lambda w: [{"test": w.test, "profile": w.profile, "random": False}],
    output:
        nc=f"{RESULTS}/simulate/{{test}}_{{profile}}.nc",
    log:
        f"{RESULTS}/logs/simulate/{{test}}_{{profile}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/simulate/{{test}}_{{profile}}.tsv"
    threads: DECLARED.threads("simulate")
    resources:
        **DECLARED.resources("simulate"),
    script:
        "../scripts/simulate.py"


# the sweep's config slice (also that of sweep_random, removal.smk)
SWEEP_CFG = {k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                    "excitation", "tachometer", "sweep")}


rule sweep:
    message:
        "Speed sweep at constant torque with harmonics and tachometer pulses"
    input:
        code=code("sweep.py"),
    params:
        cfg=SWEEP_CFG,
        random_only=False,
    output:
        nc=f"{RESULTS}/sweep/sweep.nc",
    log:
        f"{RESULTS}/logs/sweep.log",
    benchmark:
        f"{RESULTS}/benchmarks/sweep.tsv"
    threads: DECLARED.threads("sweep")
    resources:
        **DECLARED.resources("sweep"),
    script:
        "../scripts/sweep.py"


rule figures_tests:
    message:
        "Figures 7-10: speed and torque vs time in the speed- and torque-ramp tests"
    input:
        speed=expand(f"{RESULTS}/simulate/speed_{{d}}_{{p}}.nc", d=["up", "down"],
                     p=config["figures"]["test_profile"]),
        torque=expand(f"{RESULTS}/simulate/torque_{{d}}_{{p}}.nc", d=["up", "down"],
                      p=config["figures"]["test_profile"]),
        code=code("figures_tests.py"),
    output:
        **figure_outputs(7, "Test campaigns"),
        **figure_outputs(8, "Test campaigns"),
        **figure_outputs(9, "Test campaigns"),
        **figure_outputs(10, "Test campaigns"),
    log:
        f"{RESULTS}/logs/figures_tests.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_tests.tsv"
    threads: DECLARED.threads("figures_tests")
    resources:
        **DECLARED.resources("figures_tests"),
    script:
        "../scripts/figures_tests.py"
