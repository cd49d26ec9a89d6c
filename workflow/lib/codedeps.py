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
imports them, and costs a few milliseconds per rule. Standard library only: the Snakefile
loads this file before anything else.
"""

from __future__ import annotations

import ast
import os
from functools import cache
from pathlib import Path

__all__ = ["closure", "imported_modules", "module_file"]


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
    tree = ast.parse(Path(path).read_text(encoding="utf-8"), filename=str(path))
    is_pkg = Path(path).name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(tree):
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
            if base != package and not base.startswith(package + "."):
                continue
            for name in [base] + [f"{base}.{n}" for n in names if n != "*"]:
                if module_file(src, name) is not None:
                    found.update(_packages(name))
    return frozenset(found)


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
