"""A study's ``runs:``: each overlay merged and validated on its own, one results folder
each, and every malformed entry refused naming its position, its name and the key."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from gbpipe.config import load, merge, read_yaml, runs
from gbpipe.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
CONFIG, CI_CONFIG = ROOT / "config" / "config.yaml", ROOT / "config" / "ci.yaml"
STUDY = ROOT / "config" / "examples" / "study.yaml"
EXAMPLE = ROOT / "config" / "examples" / "gearbox_1planetary_2parallel.yaml"


@pytest.fixture(scope="module")
def base() -> dict:
    return merge(read_yaml(CONFIG), read_yaml(CI_CONFIG))


def _study(base: dict, *entries) -> dict:
    return merge(base, {"runs": list(entries)})


def test_each_run_equals_the_overlay_loaded_on_its_own(base, monkeypatch):
    monkeypatch.chdir(ROOT)   # overlay files are relative to the working directory
    study = runs(merge(base, read_yaml(STUDY)))
    assert list(study) == ["nominal", "planetary_parallel", "soft_coupling",
                           "stiff_housing"]
    # independent: gbpipe.config.load of the same files and keys (what --configfile does)
    expect = {
        "nominal": load(CONFIG, CI_CONFIG),
        "planetary_parallel": load(CONFIG, CI_CONFIG, EXAMPLE),
        "soft_coupling": load(CONFIG, CI_CONFIG,
                              {"bench": {"coupling": {"stiffness": 3.0e6}}}),
        "stiff_housing": load(CONFIG, CI_CONFIG,
                              {"gearbox": {"housing": {"stiffness": 8.0e8}}}),
    }
    for name, cfg in study.items():
        assert cfg["results"] == f"results/{name}"
        assert cfg["runs"] == []
        assert {k: v for k, v in cfg.items() if k != "results"} == \
               {k: v for k, v in expect[name].items() if k != "results"}, name
    # derived values follow each run's own gearbox (4 stages' worth of states differ)
    assert len(study["planetary_parallel"]["gearbox"]["stages"]) == 3
    assert study["planetary_parallel"]["gearbox"]["housing"]["stiffness"] == 5.0e8


def test_a_file_entry_is_named_by_its_stem_and_set_wins_over_file(base, tmp_path):
    overlay = tmp_path / "wide_band.yaml"
    overlay.write_text(yaml.safe_dump({"seed": 7, "bench": {"coupling":
                                                            {"stiffness": 3.5e6}}}))
    study = runs(_study(base, str(overlay),
                        {"name": "both", "file": str(overlay), "set": {"seed": 9}}))
    assert list(study) == ["wide_band", "both"]
    assert study["wide_band"]["seed"] == 7 and study["both"]["seed"] == 9
    assert study["both"]["bench"]["coupling"]["stiffness"] == 3.5e6
    assert study["both"]["results"] == "results/both"


def test_a_results_folder_other_than_results(base):
    study = runs(merge(_study(base, {"name": "a"}), {"results": "out/study1/"}))
    assert study["a"]["results"] == "out/study1/a"


def test_no_runs_is_one_run(base):
    assert runs(base) == {}
    assert runs(_study(base)) == {}


@pytest.mark.parametrize(("entries", "field", "words"), [
    ([{"name": "1st"}], "runs[0]", "must start with a letter"),
    ([{"name": "a-b"}], "runs[0]", "must start with a letter"),
    ([{"name": "a"}, {"name": "a"}], "runs[1]", "already used"),
    ([{"file": "x.yaml"}], "runs[0]", "no `name:`"),
    ([{"name": "a", "seed": 3}], "runs[0]", "unknown key(s) ['seed']"),
    ([{"name": "a", "file": "no/such/overlay.yaml"}], "runs[0]", "does not exist"),
    ([{"name": "a", "set": {"runs": [{"name": "b"}]}}], "runs[0]", "do not nest"),
    ([{"name": "a", "set": {"results": "elsewhere"}}], "runs[0]", "do not nest"),
    ([{"name": "a", "set": [1, 2]}], "runs[0].set", "mapping"),
    ([{"name": "ok"}, {"name": "bad", "set": {"gearbox": {"stiffness": [1.5e8, -1.0,
                                                                        1.5e7]}}}],
     "runs[1] (bad): gearbox.stiffness[1]", "0"),
    ([{"name": "ok"}, {"name": "typo", "set": {"bench": {"couplng": {}}}}],
     "runs[1] (typo): bench.couplng", "coupling"),
])
def test_bad_runs_are_refused_naming_entry_and_key(base, entries, field, words):
    with pytest.raises(ConfigError) as exc:
        runs(_study(base, *entries))
    assert exc.value.field == field
    assert words in str(exc.value)


def test_snakemake_refuses_a_bad_run_before_any_job_and_writes_nothing(tmp_path):
    for part in ("Snakefile", "workflow", "config", "src", "profiles"):
        (tmp_path / part).symlink_to(ROOT / part)
    study = tmp_path / "study.yaml"
    study.write_text(yaml.safe_dump({"runs": [
        {"name": "good"},
        {"name": "unstable", "set": {"bench": {"torque_controller": {"ki": 1.0e9}}}}]}))
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--cores", "1",
                           "--configfile", "config/ci.yaml", str(study)], cwd=tmp_path,
                          capture_output=True, text=True, env=env)
    assert proc.returncode != 0
    assert "runs[1] (unstable): bench.torque_controller.ki" in proc.stdout + proc.stderr
    assert not (tmp_path / "results").exists()
