# Shared helpers of the rules: the config slice of each stage (so that `params:` holds
# exactly what a stage depends on), the library modules a stage uses (so that editing them
# reruns it) and the list of final targets.


def lib(*modules):
    """Library source files a stage depends on (Snakemake tracks only the script)."""
    return [f"{LIB}/{m}" for m in modules]


def figure(n):
    """Final files of figure n: PNG, PDF and its report caption (with key numbers)."""
    stem = f"{RESULTS}/figures/fig{n:02d}"
    return [f"{stem}.png", f"{stem}.pdf", f"{RESULTS}/report/fig{n:02d}.rst"]


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
    for n in (3, 4, 5, 7, 8, 9, 10):
        targets += figure(n)
    return targets
