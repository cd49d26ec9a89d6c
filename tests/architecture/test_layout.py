"""The package map of docs/architecture.md holds: layers, module size, imports, API.

These tests read the source tree (and run ``lint-imports``): a change that breaks the
layer contract, hides an import inside a function, reaches into another module's private
names, grows a module past 400 lines, or makes a documented import return the wrong
object fails here.
"""

from __future__ import annotations

import ast
import importlib
import os
import pkgutil
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest

import gbpipe

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src" / "gbpipe"
MODULES = sorted(SRC.rglob("*.py"))
MAX_LINES = 400


def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


def test_import_linter_contract_holds():
    res = subprocess.run(["lint-imports"], cwd=ROOT, capture_output=True, text=True)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    kept = re.search(r"Contracts: (\d+) kept, (\d+) broken", res.stdout)
    assert kept and int(kept.group(1)) >= 5 and kept.group(2) == "0", res.stdout[-2000:]


def test_import_linter_checks_this_tree_whatever_gbpipe_is_installed(tmp_path):
    # lint-imports imports the root package to find it. An environment with another gbpipe
    # first on its path (an older clone installed, here a stub without gbpipe.memo) must
    # not change what is checked: the root symlink gbpipe -> src/gbpipe, found first from
    # the working directory, makes lint-imports analyse this checkout's source
    assert (ROOT / "gbpipe").resolve() == SRC
    stale = tmp_path / "gbpipe"
    stale.mkdir()
    (stale / "__init__.py").write_text("")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    res = subprocess.run(["lint-imports", "--no-cache"], cwd=ROOT, capture_output=True,
                         text=True, env=env)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert re.search(r"Contracts: \d+ kept, 0 broken", res.stdout), res.stdout[-2000:]


@pytest.mark.parametrize("path", MODULES, ids=_rel)
def test_module_is_small(path):
    n = len(path.read_text().splitlines())
    assert n <= MAX_LINES, f"{_rel(path)} has {n} lines; split it by concept (≤ {MAX_LINES})"


def _function_imports(tree: ast.AST, lines: list[str]) -> list[str]:
    bad = []
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for node in ast.walk(fn):
            if isinstance(node, ast.Import | ast.ImportFrom):
                text = lines[node.lineno - 1]
                # the one exception: an optional dependency, marked as such where imported
                if "optional dependency" not in text:
                    bad.append(f"line {node.lineno}: {text.strip()}")
    return bad


@pytest.mark.parametrize("path", MODULES, ids=_rel)
def test_imports_at_top_and_no_private_names_across_modules(path):
    text = path.read_text()
    tree = ast.parse(text)
    assert _function_imports(tree, text.splitlines()) == []
    private = [f"line {n.lineno}: {a.name} from {n.module}"
               for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
               and (n.module or "").startswith("gbpipe")
               for a in n.names if a.name.startswith("_") and not a.name.startswith("__")]
    assert private == []


def _packages() -> list[types.ModuleType]:
    pkgs = [gbpipe]
    for info in pkgutil.walk_packages(gbpipe.__path__, "gbpipe."):
        if info.ispkg:
            pkgs.append(importlib.import_module(info.name))
    return pkgs


def test_no_public_name_is_shadowed_by_a_submodule():
    # `from gbpipe.simulate import lsim` once returned the module gbpipe.simulate.lsim
    # instead of the function: a name in __all__ must not also be a submodule, unless it
    # *is* that submodule
    clashes = []
    for pkg in _packages():
        subs = {m.name for m in pkgutil.iter_modules(pkg.__path__)}
        for name in getattr(pkg, "__all__", []):
            obj = getattr(pkg, name)
            if name in subs and not isinstance(obj, types.ModuleType):
                clashes.append(f"{pkg.__name__}.{name}")
    assert clashes == []


def _documented_imports() -> list[str]:
    stmts = set()
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for m in re.finditer(r"^\s*(from gbpipe[\w.]* import [\w, ]+|import gbpipe[\w.]*)\s*$",
                             doc.read_text(), flags=re.M):
            stmts.add(m.group(1).strip())
    return sorted(stmts)


def test_docs_import_public_names_only():
    # what the docs show a user importing is the public API: each name is in its
    # package's __all__ or is a submodule, never a private or internal helper
    stmts = _documented_imports()
    assert stmts   # the fresh-interpreter test below is not vacuous
    bad = []
    for stmt in stmts:
        if not stmt.startswith("from "):
            continue
        mod, names = stmt[5:].split(" import ")
        pkg = importlib.import_module(mod)
        for name in (n.strip() for n in names.split(",")):
            is_sub = hasattr(pkg, "__path__") and importlib.util.find_spec(
                f"{mod}.{name}") is not None
            if not is_sub and name not in getattr(pkg, "__all__", ()):
                bad.append(f"{stmt}: {name}")
    assert bad == []


_CHECK = """
import importlib, importlib.util, sys, types
for stmt in sys.argv[1:]:
    ns = {}
    exec(stmt, ns)
    if stmt.startswith("from "):
        mod, names = stmt[5:].split(" import ")
        for name in [n.strip() for n in names.split(",")]:
            obj = ns[name]
            is_sub = importlib.util.find_spec(f"{mod}.{name}") is not None if hasattr(
                importlib.import_module(mod), "__path__") else False
            assert isinstance(obj, types.ModuleType) == is_sub, (stmt, name, type(obj))
            again = getattr(importlib.import_module(mod), name)
            assert again is obj, (stmt, name, "second access differs")
"""


def _by_module() -> dict[str, list[str]]:
    # documented statements grouped by the module they import from: an import-order
    # fault lies between modules, and one interpreter per module (not per statement)
    # halves the interpreters' start-ups
    groups: dict[str, list[str]] = {}
    for stmt in _documented_imports():
        mod = stmt[5:].split(" import ")[0] if stmt.startswith("from ") else stmt[7:]
        groups.setdefault(mod, []).append(stmt)
    return groups


@pytest.mark.parametrize("module", sorted(_by_module()))
def test_documented_imports_give_documented_objects_in_fresh_interpreter(module):
    stmts = _by_module()[module]
    res = subprocess.run([sys.executable, "-c", _CHECK, *stmts], cwd=ROOT,
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-2000:]


SCRIPTS = sorted((ROOT / "workflow" / "scripts").glob("*.py"))


@pytest.mark.parametrize("path", SCRIPTS, ids=_rel)
def test_workflow_scripts_use_public_api_only(path):
    tree = ast.parse(path.read_text())
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("gbpipe"):
            mod = importlib.import_module(node.module)
            for a in node.names:
                sub = importlib.util.find_spec(f"{node.module}.{a.name}") if hasattr(
                    mod, "__path__") else None
                if sub is None and a.name not in getattr(mod, "__all__", ()):
                    bad.append(f"{node.module}.{a.name} (not in __all__)")
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") \
                and not node.attr.startswith("__"):
            bad.append(f"line {node.lineno}: private attribute {node.attr}")
    assert bad == []


_OUTSIDE = re.compile(r"\.\./" + "shared|" + "DESIGN" + r"\.md|" + "WORKFLOW" + r"\.md")


def test_nothing_reads_or_cites_outside_the_repository():
    hits = []
    for top in ("src", "tests", "workflow", "docs", "benchmarks", "config"):
        for p in sorted((ROOT / top).rglob("*")):
            if p.is_file() and p.suffix in (".py", ".smk", ".md", ".yaml", ".rst", ".txt"):
                hits += [f"{_rel(p)}:{i + 1}" for i, line in
                         enumerate(p.read_text(errors="replace").splitlines())
                         if _OUTSIDE.search(line)]
    for name in ("Snakefile", "README.md"):
        hits += [f"{name}:{i + 1}" for i, line in
                 enumerate((ROOT / name).read_text().splitlines()) if _OUTSIDE.search(line)]
    assert hits == []


def test_ruff_is_clean():
    res = subprocess.run([sys.executable, "-m", "ruff", "check", "src", "tests", "workflow",
                          "benchmarks"], cwd=ROOT, capture_output=True, text=True)
    assert res.returncode == 0, res.stdout[-3000:]


def test_architecture_doc_names_only_paths_that_exist():
    # the tour in docs/architecture.md is followed on a fresh clone: every file and folder
    # it names must be there (placeholders like `method_<name>.py` and the example new
    # module `vkf.py` excepted)
    text = (ROOT / "docs" / "architecture.md").read_text()
    named = set(re.findall(r"`((?:src|tests|workflow|config|docs|benchmarks|profiles)/"
                           r"[\w./-]+)`", text))
    missing = sorted(p for p in named if not p.endswith("/vkf.py") and not (ROOT / p).exists())
    assert len(named) >= 15 and missing == []
