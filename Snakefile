# gbpipe: torque and speed on a back-to-back gearbox bench -> dynamic models of the gearbox.
# `snakemake -j2` reproduces everything; `snakemake --configfile config/ci.yaml` the CI run.
from snakemake.utils import min_version

import gbpipe.config

min_version("9.0")


configfile: "config/config.yaml"


# JSON-schema validation, then the checks a schema cannot make (stage counts, stability);
# the merged, type-coerced config replaces Snakemake's before any rule is built.
config.update(gbpipe.config.validate(config))

RESULTS = "results"
LIB = "src/gbpipe"


wildcard_constraints:
    test="speed_up|speed_down|torque_up|torque_down",
    profile="square|tapered",


include: "workflow/rules/common.smk"
include: "workflow/rules/kinematics.smk"
include: "workflow/rules/model.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/harmonics.smk"
include: "workflow/rules/identify.smk"


rule all:
    default_target: True
    input:
        all_targets(),
