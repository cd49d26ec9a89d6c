"""Library source files a workflow script depends on: the transitive import closure.

Snakemake reruns a job when its script changes, but it cannot see the library modules the
script imports. The Snakefile therefore gives every rule, as ``input.code``, the files of
:func:`closure` of its script: every ``gbpipe`` module the script imports, directly or
through other ``gbpipe`` modules, with the ``__init__.py`` of every package on the way
(importing ``gbpipe.io.tables`` executes ``gbpipe/__init__.py`` and
``gbpipe/io/__init__.py`` first). Editing any of them makes the rule, and its downstream,
rerun (docs/architecture.md, "Stage graph").

The closure is static (:mod:`ast`), so it also sees imports inside functions and lazy
imports that a run might not execute; it reads only ``src/gbpipe`` and the script, never
imports them. Parsing every module took 0.7 s of CPU at each Snakemake start, and a SLURM
job starts Snakemake twice: the names a file's text imports are therefore kept in
``.snakemake/gbpipe-codedeps.json`` (:data:`CACHE`), keyed by the SHA-256 of the text, and
parsed again only when a file changed. Which of those names are modules of ``src`` is
decided afresh at each start (a new module changes it, not the text). Standard library
only: the Snakefile loads this file before anything else.
"""

from __future__ import annotations

import ast
import atexit
import hashlib
import json
import os
import tempfile
from functools import cache
from pathlib import Path

__all__ = ["CACHE", "closure", "imported_modules", "module_file"]

#: Names imported per file text, shared by the Snakemake processes of one working
#: directory (relative: Snakemake runs in it). Only a cache: unreadable means empty.
CACHE = Path(".snakemake") / "gbpipe-codedeps.json"
_store: dict[str, list[str]] | None = None   # loaded at first use
_used: set[str] = set()                      # keys of this process's files: what is saved
_cache_file: Path | None = None              # CACHE resolved at first use


def module_file(src: Path, name: str) -> Path | None:
    """Source file of module ``name`` (dotted) under ``src``, or None when it is no module.

    A package resolves to its ``__init__.py``.
    """
    base = src.joinpath(*name.split("."))
    for path in (base / "__init__.py", base.with_suffix(".py")):
        if path.is_file():
            return path
    return None


def _packages(name: str) -> list[str]:
    # "gbpipe.io.tables" -> ["gbpipe", "gbpipe.io", "gbpipe.io.tables"]
    parts = name.split(".")
    return [".".join(parts[:k]) for k in range(1, len(parts) + 1)]


@cache
def imported_modules(path: Path, package: str, src: Path, this: str | None = None
                     ) -> frozenset[str]:
    """Dotted names of the modules of ``package`` that file ``path`` imports, with parents.

    Parameters
    ----------
    path : Path
        A script or a module of ``package``.
    package : str
        Top-level package whose modules count (``"gbpipe"``).
    src : Path
        Folder holding the package (``src``).
    this : str, optional
        Dotted name of ``path`` itself when it is a module of the package (resolves
        relative imports).

    Notes
    -----
    ``from a.b import c`` imports module ``a.b.c`` when ``c`` is a submodule, else the name
    ``c`` defined in ``a/b/__init__.py``: both cases are covered by taking ``a.b`` (and its
    parents) always, and ``a.b.c`` when such a module exists.
    """
    found: set[str] = set()
    for name in _candidates(Path(path), package, this):
        if module_file(src, name) is not None:
            found.update(_packages(name))
    return frozenset(found)


def _candidates(path: Path, package: str, this: str | None) -> list[str]:
    """Dotted names of ``package`` that ``path``'s text imports, modules or not (cached)."""
    global _store, _cache_file
    text = path.read_bytes()
    key = ":".join([hashlib.sha256(text).hexdigest(), package, this or "",
                    str(path.name == "__init__.py")])
    if _store is None:
        # resolved now: the process may change directory before it exits
        _cache_file = CACHE.resolve()
        _store = _load(_cache_file)
        atexit.register(_save)
    if key not in _store:
        _store[key] = _parse(text, str(path), package, this, path.name == "__init__.py")
    _used.add(key)
    return _store[key]


def _parse(text: bytes, filename: str, package: str, this: str | None, is_pkg: bool
           ) -> list[str]:
    # `import a.b` -> a.b; `from a.b import c, d` -> a.b, a.b.c, a.b.d (c and d may be
    # names defined in a/b/__init__.py rather than modules: imported_modules decides)
    found: set[str] = set()
    for node in ast.walk(ast.parse(text, filename=filename)):
        if isinstance(node, ast.Import):
            bases = [(alias.name, []) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import: resolve against this module's package
                if this is None:
                    continue
                anchor = this.split(".")
                anchor = anchor[:len(anchor) - node.level + (1 if is_pkg else 0)]
                base = ".".join(anchor + ([base] if base else []))
            bases = [(base, [alias.name for alias in node.names])]
        else:
            continue
        for base, names in bases:
            if base == package or base.startswith(package + "."):
                found.update([base] + [f"{base}.{n}" for n in names if n != "*"])
    return sorted(found)


def _load(path: Path) -> dict[str, list[str]]:
    try:
        store = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return store if isinstance(store, dict) else {}


def _save() -> None:
    """Write the entries of this process's files, atomically (Snakemake processes of one
    directory end at any time: the last complete file wins, never a torn one), when they
    differ from the file's; a read-only directory keeps no cache. Entries of files that
    changed since are dropped, so the file stays the size of the library."""
    if _store is None or _cache_file is None or set(_load(_cache_file)) == _used:
        return
    try:
        _cache_file.parent.mkdir(exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=_cache_file.parent, prefix=f".{_cache_file.name}.",
                                   suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump({k: _store[k] for k in sorted(_used)}, fh)
        os.replace(tmp, _cache_file)
    except OSError:
        return


@cache
def _closure(script: str, src: str, package: str) -> frozenset[str]:
    src_path = Path(src)
    todo = set(imported_modules(Path(script), package, src_path))
    done: set[str] = set()
    while todo:
        name = todo.pop()
        done.add(name)
        path = module_file(src_path, name)
        todo |= imported_modules(path, package, src_path, this=name) - done
    return frozenset(done)


def closure(script: str | os.PathLike, src: str | os.PathLike = "src",
            package: str = "gbpipe") -> list[str]:
    """Source files (``src/...``, sorted) a script imports from ``package``, transitively.

    Parameters
    ----------
    script : path-like
        The workflow script, e.g. ``workflow/scripts/identify.py``.
    src : path-like
        Folder holding the package, relative to the working directory or absolute.
    package : str
        The package whose modules are followed.

    Returns
    -------
    list of str
        Paths as ``src`` joined with the module's file, so they match Snakemake's inputs.
    """
    names = _closure(os.fspath(script), os.fspath(src), package)
    files = {module_file(Path(src), n) for n in names}
    return sorted(os.fspath(f) for f in files if f is not None)
