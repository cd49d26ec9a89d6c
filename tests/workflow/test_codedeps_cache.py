"""workflow/lib/codedeps.py keeps the names each file imports between processes
(``.snakemake/gbpipe-codedeps.json``): the closure it gives must stay the one of the files
as they are now, whatever the cache holds.

A package of four modules is written in a scratch directory; each step runs the closure of
one script in a new process (the cache lives from one Snakemake start to the next), and
the expected closure is read off the files by hand.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.workflow.runs import ROOT

_CLOSURE = f"""
import json, sys
sys.path.insert(0, {str(ROOT / "workflow" / "lib")!r})
import codedeps
print(json.dumps(codedeps.closure("script.py", "src", package="pkg")))
"""


def _closure(work: Path) -> list[str]:
    proc = subprocess.run([sys.executable, "-c", _CLOSURE], cwd=work, capture_output=True,
                          text=True, check=True)
    return json.loads(proc.stdout)


def _write(work: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        (work / name).parent.mkdir(parents=True, exist_ok=True)
        (work / name).write_text(text)


def test_the_cached_closure_follows_every_change_of_the_files(tmp_path):
    _write(tmp_path, {"script.py": "from pkg import a\n",
                      "src/pkg/__init__.py": "",
                      "src/pkg/a.py": "from . import b\nfrom pkg.c import helper\n"
                                      "from pkg import d\n",   # no module d (yet)
                      "src/pkg/b.py": "def f():\n    import pkg.c\n",
                      "src/pkg/c.py": "helper = 1\n"})
    everything = ["src/pkg/__init__.py", "src/pkg/a.py", "src/pkg/b.py", "src/pkg/c.py"]
    assert _closure(tmp_path) == everything
    cache = tmp_path / ".snakemake" / "gbpipe-codedeps.json"
    assert len(json.loads(cache.read_text())) == 5   # the script and the four modules
    assert _closure(tmp_path) == everything           # read from the cache

    # a changed text is parsed again: b no longer imports c, nor does a
    _write(tmp_path, {"src/pkg/b.py": "x = 1\n",
                      "src/pkg/a.py": "from . import b\nfrom pkg import d\n"})
    without_c = ["src/pkg/__init__.py", "src/pkg/a.py", "src/pkg/b.py"]
    assert _closure(tmp_path) == without_c
    assert len(json.loads(cache.read_text())) == 4   # c's and the old texts' entries dropped

    # an unchanged text whose imported name became a module: a's `from pkg import d`
    # (existence is decided afresh at each start, not cached)
    _write(tmp_path, {"src/pkg/d.py": ""})
    assert _closure(tmp_path) == sorted([*without_c, "src/pkg/d.py"])

    # a torn cache file is no cache, never a wrong closure
    cache.write_text('{"not": "json"')
    assert _closure(tmp_path) == sorted([*without_c, "src/pkg/d.py"])
    assert len(json.loads(cache.read_text())) == 5
