# TSA variant name -> cycles removed (config order kept: figures 12-17 use the first three)
TSA_VARIANTS = {v["name"]: v["cycles"] for v in config["tsa"]["variants"]}
TSA_AVERAGING = {v["name"]: v["averaging"] for v in config["tsa"]["variants"]}


rule spectra:
    message:
        "Power and order spectra vs rpm of the raw sweep (Fig 11)"
    input:
        record=f"{RESULTS}/sweep/sweep.nc",
        code=code("spectra.py"),
    params:
        spectra=config["spectra"],
        what="raw sweep",
    output:
        nc=f"{RESULTS}/spectra/sweep_raw.nc",
    log:
        f"{RESULTS}/logs/spectra.log",
    benchmark:
        f"{RESULTS}/benchmarks/spectra.tsv"
    priority: SWEEP_PATH
    threads: DECLARED.threads("spectra")
    resources:
        **DECLARED.resources("spectra"),
    script:
        "../scripts/spectra.py"


rule tsa:
    message:
        "Harmonic removal by TSA on the sweep, variants {params.variants}"
    input:
        sweep=f"{RESULTS}/sweep/sweep.nc",
        bench=f"{RESULTS}/model/bench.nc",
        code=code("tsa.py"),
    params:
        # one job runs every variant on the sweep read once (1.2 M samples); the settings
        # of each variant, in the order of tsa.variants
        tsa={v: {"n_cycles": config["tsa"]["n_cycles"], "unbiased": config["tsa"]["unbiased"],
                 "averaging": TSA_AVERAGING[v], "cycles": cycles}
             for v, cycles in TSA_VARIANTS.items()},
        spectra=config["spectra"],
        stages=config["gearbox"]["stages"],
        excitation=config["excitation"],
        noise=config["sweep"]["noise"],  # the pulsating torque: the motor family
        variants=", ".join(TSA_VARIANTS),
    output:
        nc=expand(f"{RESULTS}/tsa/{{variant}}.nc", variant=list(TSA_VARIANTS)),
    log:
        f"{RESULTS}/logs/tsa.log",
    benchmark:
        f"{RESULTS}/benchmarks/tsa.tsv"
    priority: SWEEP_PATH
    threads: DECLARED.threads("tsa")
    resources:
        **DECLARED.resources("tsa"),
    script:
        "../scripts/tsa.py"


rule figures_harmonics:
    message:
        "Figures 11-17 and the resonance-band check"
    input:
        raw=rules.spectra.output.nc,
        variants=expand(f"{RESULTS}/tsa/{{v}}.nc", v=list(TSA_VARIANTS)),
        code=code("figures_harmonics.py"),
    params:
        variants=list(TSA_VARIANTS),
        n_cycles=config["tsa"]["n_cycles"],
        stages=config["gearbox"]["stages"],
        formats=FIGURE_FORMATS,
    output:
        **{k: v for n in range(11, 18) for k, v in figure_outputs(n, "Harmonic removal").items()},
        **figure_outputs("mode_band", "Harmonic removal", name="mode_band"),
    log:
        f"{RESULTS}/logs/figures_harmonics.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_harmonics.tsv"
    threads: DECLARED.threads("figures_harmonics")
    resources:
        **DECLARED.resources("figures_harmonics"),
    script:
        "../scripts/figures_harmonics.py"
