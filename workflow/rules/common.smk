# Shared helpers of the rules: the config slice of each stage (so that `params:` holds
# exactly what a stage depends on), the library modules a stage uses (so that editing them
# reruns it) and the list of final targets.


def lib(*modules):
    """Library source files a stage depends on (Snakemake tracks only the script)."""
    return [f"{LIB}/{m}" for m in modules]


def figure(n):
    return [f"{RESULTS}/figures/fig{n:02d}.png", f"{RESULTS}/figures/fig{n:02d}.pdf"]


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
