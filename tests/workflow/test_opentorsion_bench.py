"""config/examples/opentorsion_bench.yaml end to end: a bench modelled in openTorsion (a
model file with a sibling helper module and dampers to ground) fitted to records the
test writes, and the fitted overlay run again.

The records: the example's chain, expanded from the model file as the workflow expands
it, with one jaw coupling 20 % softer (``drivetrain.shafts[2].stiffness`` × 0.8),
simulated as the bench logs it (tests/measured/shaftline_bench.py: exact ZOH, the drive
motor excited by a band-limited random torque, sensor noise, the excitation logged; a
CSV drive log and a TDMS DAQ file). The fit starts from the model file's values; the
softened coupling's 95 % interval must hold its true value. The fitted overlay
(``results/fit/ice1.yaml``) is then given to Snakemake as one more ``--configfile``: the
imported chain takes the fitted values and the fit reruns from them. Last, the fitted
chain is exported (``python -m gbpipe export-opentorsion``) and reopened in openTorsion:
the fitted value is there and openTorsion's modes equal gbpipe's to 1e-9.
"""

from __future__ import annotations

import shutil

import numpy as np
import yaml

from gbpipe import io
from gbpipe.__main__ import main
from gbpipe.config import load
from gbpipe.fit.keypath import get_value
from gbpipe.model.opentorsion_files import load_model_file
from tests.measured.shaftline_bench import write_bench
from tests.model.test_opentorsion_files import gb_modes, ot_modes
from tests.workflow.runs import copy_repo, snakemake

EXAMPLE = ("config/ci.yaml", "config/examples/opentorsion_bench.yaml")
#: The change written into the record (key path -> factor).
CHANGED = {"drivetrain.shafts[2].stiffness": 0.8}


def test_opentorsion_bench_fits_and_its_overlay_reruns(tmp_path, monkeypatch):
    work = copy_repo(tmp_path)
    monkeypatch.chdir(work)             # the model file's path is the repository's
    cfg = load("config/config.yaml", *EXAMPLE)
    assert not {"noise", "campaign", "bench"} & set(
        yaml.safe_load((work / EXAMPLE[1]).read_text()))
    truth = write_bench(work / "ice1", cfg, perturb=CHANGED, duration=20.0, seed=3,
                        tacho_disk="n8", name="ice1")
    snakemake(work, "--configfile", *EXAMPLE, "--nolock", "results/fit/ice1.nc")
    fit = io.read(work / "results" / "fit" / "ice1.nc")
    names = [str(p) for p in fit.parameter.values]
    assert names == cfg["fit"]["free"]
    for k, path in enumerate(names):
        true = get_value(truth.cfg, path)
        # the record is of the changed chain, the fit started from the model file's
        assert true == CHANGED.get(path, 1.0) * get_value(cfg, path)
        assert float(fit.interval_lower[k]) <= true <= float(fit.interval_upper[k]), path
    k = names.index("drivetrain.shafts[2].stiffness")
    fitted = float(fit.estimate.values[k])
    # the overlay holds the fitted values as config; the imported chain takes them
    overlay = work / "fitted.yaml"
    shutil.copy(work / "results" / "fit" / "ice1.yaml", overlay)
    rerun = load("config/config.yaml", *EXAMPLE, overlay)
    assert get_value(rerun, names[k]) == fitted
    assert rerun["drivetrain"]["opentorsion"]["source"].endswith("model.py:test_bench")
    snakemake(work, "--configfile", *EXAMPLE, str(overlay), "--nolock",
              "results/fit/ice1.nc")
    again = io.read(work / "results" / "fit" / "ice1.nc")
    # the second fit started from the first one's values and stays inside its interval
    assert float(again.prior.values[k]) == fitted
    value = float(again.estimate.values[k])
    assert float(fit.interval_lower[k]) <= value <= float(fit.interval_upper[k])
    # the fitted chain back to openTorsion: the value fitted, the modes of the same chain
    out = work / "fitted_bench.py"
    assert main(["export-opentorsion", "config/config.yaml", *EXAMPLE, str(overlay),
                 "-o", str(out)]) == 0
    asm, _ = load_model_file(f"{out}:assembly")
    assert asm.shaft_elements[2].k == fitted
    np.testing.assert_allclose(ot_modes(asm), gb_modes(rerun["drivetrain"]), rtol=1e-9)
