rule model:
    message:
        "Torsional models of one gearbox and of the back-to-back bench (Figs 3-5), and the "
        "true FRFs and modes of every identification pairing"
    input:
        code=code("model.py"),
    params:
        model={**{k: config[k] for k in ("gearbox", "bench", "model")}, **DRIVETRAIN},
        # the identification grid and mode limits of the truth (identify reads truth.nc)
        truth={k: config["identify"][k] for k in ("pairings", "frf", "zeta_max")},
    output:
        gearbox=f"{RESULTS}/model/gearbox.nc",
        bench=f"{RESULTS}/model/bench.nc",
        truth=f"{RESULTS}/model/truth.nc",
    log:
        f"{RESULTS}/logs/model.log",
    benchmark:
        f"{RESULTS}/benchmarks/model.tsv"
    priority: CRITICAL_PATH
    threads: DECLARED.threads("model")
    resources:
        **DECLARED.resources("model"),
    script:
        "../scripts/model.py"


rule figures_model:
    message:
        "Figures 3 (gearbox Bode), 4 (bench Bode) and 5 (topology)"
    input:
        gearbox=rules.model.output.gearbox,
        bench=rules.model.output.bench,
        code=code("figures_model.py"),
    params:
        model={k: config[k] for k in ("gearbox", "bench")},
        formats=FIGURE_FORMATS,
    output:
        **figure_outputs(3, "Model"),
        **figure_outputs(4, "Model"),
        **figure_outputs(5, "Model"),
    log:
        f"{RESULTS}/logs/figures_model.log",
    benchmark:
        f"{RESULTS}/benchmarks/figures_model.tsv"
    threads: DECLARED.threads("figures_model")
    resources:
        **DECLARED.resources("figures_model"),
    script:
        "../scripts/figures_model.py"
