"""docs/architecture.md "Data contract" is true of a CI run, both ways, with provenance.

Every output listed there holds exactly the variables listed, on the dimensions and in
the units listed; every output carries the provenance of the data contract: gbpipe
version, the config slice and its hash, and each source file with its SHA-256.
"""

from __future__ import annotations

import hashlib
import json
import re

import gbpipe
from gbpipe import io
from tests.conftest import ROOT

_ENTRY = re.compile(r"^\*\*`([^`]+)`\*\* — dims (.*?)\. (.*)$", re.M)
_VAR = re.compile(r"`([^`]+)` \(([^)]*)\) \[([^\]]*)\]")


def _contract() -> dict[str, dict[str, tuple[tuple[str, ...], str]]]:
    text = (ROOT / "docs" / "architecture.md").read_text()
    out = {}
    for path, _dims, variables in _ENTRY.findall(text):
        out[path] = {name: (tuple(d for d in dims.split(",") if d), units)
                     for name, dims, units in _VAR.findall(variables)}
    return out


def _resolve(run, pattern: str):
    glob = re.sub(r"\{[a-z_]+\}", "*", pattern)
    return sorted((run / "results").glob(glob))


def _run_of(pattern: str, ci_run, measured_run):
    # outputs of bench records (and their virtual sensors) come from the measured
    # example, the rest from the CI run
    bench = "measured/" in pattern or pattern.startswith("virtual/")
    return measured_run[0] if bench else ci_run


def test_contract_lists_every_stage_output(ci_run, measured_run):
    # both ways: every NetCDF a run writes matches a documented pattern
    patterns = [re.compile(re.sub(r"\\\{[a-z_]+\\\}", "[^/]+", re.escape(p)) + "$")
                for p in _contract()]
    for run in (ci_run, measured_run[0]):
        for path in (run / "results").rglob("*.nc"):
            rel = path.relative_to(run / "results").as_posix()
            assert any(p.match(rel) for p in patterns), f"{rel} is not in the data contract"


def test_every_documented_output_matches_the_contract(ci_run, measured_run):
    for pattern, variables in _contract().items():
        files = _resolve(_run_of(pattern, ci_run, measured_run), pattern)
        assert files, f"no output of the CI or measured-example run matches {pattern}"
        ds = io.read(files[0])
        got = {v: (tuple(ds[v].dims), str(ds[v].attrs["units"])) for v in ds.data_vars}
        assert got == variables, f"{pattern}: the file and docs/architecture.md differ"


def test_every_netcdf_carries_provenance(ci_run, measured_run):
    checked = 0
    paths = [(ci_run, p) for p in sorted((ci_run / "results").rglob("*.nc"))]
    paths += [(measured_run[0], p) for p in sorted((measured_run[0] / "results").rglob("*.nc"))]
    for run, path in paths:
        attrs = io.read(path).attrs
        assert attrs["gbpipe_version"] == gbpipe.__version__
        assert io.config_sha256(json.loads(attrs["config"])) == attrs["config_sha256"]
        sources = json.loads(attrs["source_files"])
        assert sources, f"{path} names no source file"
        for src in sources:
            data = (run / src["path"]).read_bytes()
            # the inputs are unchanged since the run: their bytes hash to what was stored
            assert hashlib.sha256(data).hexdigest() == src["sha256"], (path, src["path"])
            assert len(data) == src["bytes"]
        checked += 1
    assert checked >= 20
