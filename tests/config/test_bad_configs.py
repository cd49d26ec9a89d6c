"""Issue 11's table of bad configurations: each is refused at load naming its key path,
and ``snakemake -n`` with it exits non-zero, names the key path, and writes nothing.

Snakemake runs in a temporary directory holding links to the Snakefile, ``workflow/``,
``config/`` and ``src/``, so the repository's ``results/`` is never at risk; that no
``results/`` appears there is asserted for every case.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from bad_configs import CASES

from gbpipe.config import load
from gbpipe.errors import ConfigError
from tests.workflow.runs import snakemake_env

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CONFIG, CI_CONFIG = ROOT / "config" / "config.yaml", ROOT / "config" / "ci.yaml"
IDS = [c[0] for c in CASES]


def test_the_base_every_case_changes_is_accepted():
    # the control: without an overlay the same load succeeds, so each refusal below is
    # the overlay's doing, not the base's
    cfg = load(CONFIG, CI_CONFIG)
    assert cfg["campaign"]["tests"] == ["speed_up", "speed_down"]


@pytest.mark.parametrize(("overlay", "field"), [c[2:] for c in CASES], ids=IDS)
def test_refused_at_load_naming_the_key(overlay, field):
    with pytest.raises(ConfigError) as exc:
        load(CONFIG, CI_CONFIG, overlay)
    assert exc.value.field == field
    assert f"'{field}'" in str(exc.value)


@pytest.fixture(scope="session")
def snakemake_runs(tmp_path_factory):
    """Exit status, stderr and the results/ check of ``snakemake -n`` for every case."""
    base = tmp_path_factory.mktemp("snakemake_bad")
    cases = []
    for cid, _, overlay, _ in CASES:
        d = base / cid
        d.mkdir()
        for name in ("Snakefile", "workflow", "config", "src"):
            (d / name).symlink_to(ROOT / name)
        (d / "bad.yaml").write_text(yaml.safe_dump(overlay))
        cases.append({"dir": str(d), "argv": ["-n", "--cores", "1", "--configfile",
                                              "config/ci.yaml", "bad.yaml"]})
    (base / "cases.json").write_text(json.dumps(cases))
    # this checkout's src first on PYTHONPATH (the batch script's folder, not the
    # repository's, is first on its sys.path): the gbpipe tested is this one, not whichever
    # is installed
    subprocess.run([sys.executable, str(HERE / "snakemake_batch.py"), str(base / "cases.json"),
                    str(base / "codes.json")], check=True, env=snakemake_env(ROOT),
                   timeout=3600)  # a hang guard only: ~70 dry runs on a loaded machine
    codes = json.loads((base / "codes.json").read_text())
    return {cid: (code, (base / cid / "stderr").read_text() + (base / cid / "stdout").read_text(),
                  (base / cid / "results").exists())
            for (cid, *_), code in zip(CASES, codes, strict=True)}


@pytest.mark.parametrize(("cid", "field"), [(c[0], c[3]) for c in CASES], ids=IDS)
def test_snakemake_dry_run_refuses(snakemake_runs, cid, field):
    code, output, wrote_results = snakemake_runs[cid]
    assert code != 0
    assert f"config field '{field}'" in output
    assert not wrote_results


def test_batch_runner_equals_the_snakemake_command(snakemake_runs, tmp_path):
    """The forked runner gives what the `snakemake` command gives (one case, for real)."""
    cid, _, overlay, field = CASES[0]
    for name in ("Snakefile", "workflow", "config", "src"):
        (tmp_path / name).symlink_to(ROOT / name)
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(overlay))
    run = subprocess.run(["snakemake", "-n", "--cores", "1", "--configfile", "config/ci.yaml",
                          "bad.yaml"], cwd=tmp_path, capture_output=True, text=True,
                         env=snakemake_env(ROOT), timeout=1800)  # a hang guard only
    assert (run.returncode != 0) == (snakemake_runs[cid][0] != 0)
    # Snakemake logs its error to stdout or stderr depending on its log handler: both count
    assert f"config field '{field}'" in run.stdout + run.stderr
    assert not (tmp_path / "results").exists()
