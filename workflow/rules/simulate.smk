# the test records' config slice (rule `campaign`: every record the workflow reads, in one
# job)
SIMULATE_CFG = {**{k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                          "excitation", "tachometer")}, **DRIVETRAIN}


def _identified_tests():
    # every identified test and its validation record (rules.identify reads both after
    # TSA and after each removal version)
    tests = list(config["identify"]["tests"])
    return sorted({*tests, *(_partner(t) for t in tests)})


# the records of rule removal_tests (TSA and every removal version): every identified test
# and its validation record, on every identified profile
REMOVAL_RECORDS = [(t, p) for t in _identified_tests()
                   for p in config["identify"]["profiles"]]


def _campaign_records():
    # every record a stage reads or a target names, as (test, profile): the campaign, the
    # ramp tests of figures 7-10, and the identified tests with their validation records
    camp = config["campaign"]
    records = {(t, p) for t in camp["tests"] for p in camp["profiles"]}
    if not config.get("drivetrain"):  # figures 7-10 are the paper bench's
        records |= {(t, config["figures"]["test_profile"])
                    for t in ("speed_up", "speed_down", "torque_up", "torque_down")}
    return sorted(records | set(REMOVAL_RECORDS))


CAMPAIGN_RECORDS = _campaign_records()
# the records with a random-only twin: those a removal version is scored on
CAMPAIGN_TWINS = REMOVAL_RECORDS if REMOVAL_VERSIONS else []


rule campaign:
    message:
        "The test campaign: {params.n_records} closed-loop records, clean and measured-like, "
        "and {params.n_twins} again with the same seeds and no angle-locked excitation "
        "(random-only)"
    input:
        code=code("simulate.py"),
    params:
        cfg=SIMULATE_CFG,
        # in the order of the outputs: every record, then every twin
        records=[{"test": t, "profile": p, "random": False} for t, p in CAMPAIGN_RECORDS]
        + [{"test": t, "profile": p, "random": True} for t, p in CAMPAIGN_TWINS],
        n_records=len(CAMPAIGN_RECORDS),
        n_twins=len(CAMPAIGN_TWINS),
    output:
        # one job for all: a record simulates in ~0.2 s and writes in ~0.1 s, while a job
        # of its own cost ~1 s more to start (Python and its imports)
        nc=[f"{RESULTS}/simulate/{t}_{p}.nc" for t, p in CAMPAIGN_RECORDS],
        random=[f"{RESULTS}/simulate/random/{t}_{p}.nc" for t, p in CAMPAIGN_TWINS],
    log:
        f"{RESULTS}/logs/campaign.log",
    benchmark:
        f"{RESULTS}/benchmarks/campaign.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("campaign")
    resources:
        **DECLARED.resources("campaign"),
    script:
        "../scripts/simulate.py"


# the sweep's config slice
SWEEP_CFG = {k: config[k] for k in ("seed", "gearbox", "bench", "campaign", "noise",
                                    "excitation", "tachometer", "sweep")}
# the removal comparison (removal.methods) scores against the random-only sweep
SWEEP_TWIN = bool(config["removal"]["methods"])


rule sweep:
    message:
        "Speed sweep at constant torque with harmonics and tachometer pulses{params.twin}"
    input:
        code=code("sweep.py"),
    params:
        cfg=SWEEP_CFG,
        twin=(", and again with the same seeds and no angle-locked excitation (random-only)"
              if SWEEP_TWIN else ""),
    output:
        # one job for both: the twin repeats the sweep with the excitation off
        nc=f"{RESULTS}/sweep/sweep.nc",
        random=f"{RESULTS}/sweep/sweep_random.nc" if SWEEP_TWIN else [],
    log:
        f"{RESULTS}/logs/sweep.log",
    benchmark:
        f"{RESULTS}/benchmarks/sweep.tsv"
    priority: SWEEP_PATH
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
    params:
        formats=FIGURE_FORMATS,
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
