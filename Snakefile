# gbpipe: torque and speed on a back-to-back gearbox bench -> dynamic models of the gearbox.
# `snakemake -j2` reproduces everything; `snakemake --configfile config/ci.yaml` the CI run.
import compileall
import sys

from snakemake.utils import min_version

# Every job imports gbpipe from src/ (an editable install). Where Python is told not to
# write bytecode (PYTHONDONTWRITEBYTECODE, set in some CI images and sandboxes), each job
# would compile the ~100 modules it imports again, about 0.1 s per job: compile them once
# here (a few ms when they are up to date; nothing happens where src/ is read-only).
compileall.compile_dir(f"{workflow.basedir}/src/gbpipe", quiet=2)

import gbpipe.config
import gbpipe.io
from gbpipe.simulate.profiles import TESTS

# workflow/lib holds the workflow's own helpers (not part of the gbpipe library)
sys.path.insert(0, f"{workflow.basedir}/workflow/lib")
import codedeps
import jobresources

min_version("9.0")


configfile: "config/config.yaml"


# A study (`runs:`, a list of overlays) becomes one Snakemake module per run, each this
# same Snakefile with its own validated config and results folder (workflow/rules/runs.smk).
RUNS = gbpipe.config.runs(config)
if not RUNS:
    # JSON-schema validation, then the checks a schema cannot make (stage counts,
    # stability); the merged, type-coerced config replaces Snakemake's before any rule is
    # built.
    config.update(gbpipe.config.validate(config))

RESULTS = config.get("results", "results")
SRC = "src"
# threads, memory and run time of every rule, measured (workflow/resources.yaml)
DECLARED = jobresources.Declared()


onstart:
    # A job killed with SIGKILL cannot remove its temporary; the next run does, before any
    # job writes (temporaries have one recognisable name, see gbpipe.io.atomic_path).
    for stale in gbpipe.io.clean_temporaries(RESULTS):
        print(f"removed stale temporary {stale}", file=sys.stderr)


if RUNS:

    include: "workflow/rules/runs.smk"

    rule all:
        default_target: True
        input:
            run_targets(),

else:

    wildcard_constraints:
        # every ramp test (figures 7-10 show all four) and the designed-excitation tests
        test="|".join([*TESTS, *(d["name"] for d in config["campaign"]["designed"])]),
        profile="square|tapered",

    include: "workflow/rules/common.smk"
    include: "workflow/rules/kinematics.smk"
    include: "workflow/rules/model.smk"
    include: "workflow/rules/simulate.smk"
    include: "workflow/rules/harmonics.smk"
    include: "workflow/rules/design.smk"
    include: "workflow/rules/identify.smk"
    include: "workflow/rules/removal.smk"
    include: "workflow/rules/measured.smk"
    include: "workflow/rules/modes.smk"
    include: "workflow/rules/fit.smk"
    include: "workflow/rules/virtual.smk"

    rule all:
        default_target: True
        input:
            all_targets(),
