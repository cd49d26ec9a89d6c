# Shared helpers of the rules: the config slice of each stage (so that `params:` holds
# exactly what a stage depends on), the library modules a stage uses (so that editing them
# reruns it), the identification versions and validation partners several stages read,
# and the list of final targets.
from gbpipe.identify import VALIDATION_PARTNER, VERSIONS
from gbpipe.simulate import base_test


# identification versions that are a removal method of their own (rule removal_tests in
# removal.smk writes them, and the tsa version, in one job per record)
REMOVAL_VERSIONS = [v for v in config["identify"]["versions"] if v not in VERSIONS]


# Scheduling priorities for runs on few cores. Snakemake's greedy scheduler otherwise takes
# the ready job with the largest input files first: the figures of the model and the tests
# ran before the sweep, and the figures of the sweep before the fit, whose chains then
# ended the CI run on 2 cores alone. First the chain that sets the wall time (the model and
# the records, their harmonic removal, identification, its table and predicted bands, the
# physical fit and its figure), then the sweep's chain (sweep, spectra, TSA, removal); the
# figures and tables off both fill the gaps (priority 0).
CRITICAL_PATH = 2
SWEEP_PATH = 1


def _partner(test):
    # the validation record of a test: the mirror of its ramp test (a designed test is
    # validated on the plain mirror test, data the fit never saw)
    return VALIDATION_PARTNER[base_test(config, test)]


def code(script):
    """Library source files `workflow/scripts/<script>` imports, transitively: the
    `input.code` of its rule, so that editing any of them reruns the rule (Snakemake itself
    tracks only the script)."""
    return codedeps.closure(f"{workflow.basedir}/workflow/scripts/{script}", SRC)


#: File formats of every figure (figures.formats; the schema requires png, which the
#: report embeds). A figure rule passes them to its script (params.formats), whose
#: gbpipe.figures.style.formats block saves them, PNG first.
FIGURE_FORMATS = config["figures"]["formats"]


def figure_files(stem):
    """The image files of a figure stem: `<stem>.<format>`, one per FIGURE_FORMATS."""
    return [f"{stem}.{ext}" for ext in FIGURE_FORMATS]


def _figure_paths(n):
    """Stem and report caption of figure n (`figNN` for a number, `fig_<n>` for a name)."""
    name = f"fig{n:02d}" if isinstance(n, int) else f"fig_{n}"
    return f"{RESULTS}/figures/{name}", f"{RESULTS}/report/{name}.rst"


def figure(n):
    """Final files of figure n: one image per format and its report caption (with key
    numbers)."""
    stem, rst = _figure_paths(n)
    return figure_files(stem) + [rst]


def image_outputs(name, stem, caption, category):
    """Named rule outputs of one figure: `<name>_<format>` for every format of
    FIGURE_FORMATS, the PNG into `snakemake --report` (captioned by `caption`, a path
    relative to this rules folder)."""
    return {f"{name}_{ext}": (report(path, caption=caption, category=category)
                              if ext == "png" else path)
            for ext, path in zip(FIGURE_FORMATS, figure_files(stem), strict=True)}


def figure_outputs(n, category, name=None):
    """Named rule outputs of figure n: its images (`image_outputs`, captioned by the RST file
    the same rule writes) and `<name>_caption`. `name` defaults to `fig<n>`."""
    stem, rst = _figure_paths(n)
    name = name or f"fig{n}"
    return {**image_outputs(name, stem, f"../../{rst}", category), f"{name}_caption": rst}


# a described drivetrain (docs/drivetrain.md) joins every config slice that builds the bench
# model; the paper's slices are unchanged without one
DRIVETRAIN = {"drivetrain": config["drivetrain"]} if config.get("drivetrain") else {}


def all_targets():
    if config["measured"]:
        return measured_targets() + fit_targets() + virtual_targets()
    if config.get("drivetrain"):
        # a described drivetrain's campaign: the gearbox-specific stages (kinematics,
        # Table 2, the sweep, TSA, harmonic removal, figures 7-17) are the paper bench's
        camp = config["campaign"]
        return ([f"{RESULTS}/model/bench.nc", f"{RESULTS}/model/truth.nc"]
                + expand(f"{RESULTS}/simulate/{{test}}_{{profile}}.nc", test=camp["tests"],
                         profile=camp["profiles"])
                + identify_targets() + design_targets() + fit_targets())
    targets = [
        f"{RESULTS}/kinematics/frequencies.nc",
        f"{RESULTS}/tables/table2.csv",
        f"{RESULTS}/model/gearbox.nc",
        f"{RESULTS}/model/bench.nc",
        f"{RESULTS}/model/truth.nc",
    ]
    camp = config["campaign"]
    targets += expand(f"{RESULTS}/simulate/{{test}}_{{profile}}.nc", test=camp["tests"],
                      profile=camp["profiles"])
    targets.append(f"{RESULTS}/sweep/sweep.nc")
    targets.append(f"{RESULTS}/spectra/sweep_raw.nc")
    targets += expand(f"{RESULTS}/tsa/{{v}}.nc", v=list(TSA_VARIANTS))
    for n in (3, 4, 5, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, "mode_band"):
        targets += figure(n)
    return (targets + identify_targets() + design_targets() + removal_targets()
            + fit_targets())
