# Shared helpers of the rules: the config slice of each stage (so that `params:` holds
# exactly what a stage depends on), the library modules a stage uses (so that editing them
# reruns it) and the list of final targets.


def lib(*modules):
    """Library source files a stage depends on (Snakemake tracks only the script)."""
    return [f"{LIB}/{m}" for m in modules]


def figure(n):
    """Final files of figure n: PNG, PDF and its report caption (with key numbers)."""
    name = f"fig{n:02d}" if isinstance(n, int) else f"fig_{n}"
    stem = f"{RESULTS}/figures/{name}"
    return [f"{stem}.png", f"{stem}.pdf", f"{RESULTS}/report/{name}.rst"]


def figure_outputs(n, category):
    """Rule outputs of figure n; the PNG goes into `snakemake --report`, captioned by the
    RST file the same rule writes (the caption path is relative to this rules folder)."""
    png, pdf, rst = figure(n)
    return [report(png, caption=f"../../{rst}", category=category), pdf, rst]


def all_targets():
    targets = [
        f"{RESULTS}/kinematics/frequencies.nc",
        f"{RESULTS}/tables/table2.csv",
        f"{RESULTS}/model/gearbox.nc",
        f"{RESULTS}/model/bench.nc",
    ]
    camp = config["campaign"]
    targets += expand(f"{RESULTS}/simulate/{{test}}_{{profile}}.nc", test=camp["tests"],
                      profile=camp["profiles"])
    targets.append(f"{RESULTS}/sweep/sweep.nc")
    targets.append(f"{RESULTS}/spectra/sweep_raw.nc")
    targets += expand(f"{RESULTS}/tsa/{{v}}.nc", v=list(TSA_VARIANTS))
    for n in (3, 4, 5, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, "mode_band"):
        targets += figure(n)
    return targets + identify_targets()
