"""openTorsion model files: a Python model run as a script, TORS JSON read and written.

openTorsion users publish a model in one of two forms (docs/opentorsion.md):

* a Python file with a function returning an :class:`opentorsion.Assembly`, often
  importing a helper module beside it (``import utils``). :func:`load_model_file` runs it
  as Python runs a script: its folder first on ``sys.path`` while it runs (restored
  after, and the modules it imported from that folder forgotten, so that another model's
  ``utils`` is never this one's; a same-named module imported earlier from elsewhere is
  hidden meanwhile), the working directory unchanged. Running a file named
  in a config is a trust decision of the user, as running a Snakefile is.
* openTorsion's own JSON model format, TORS (:class:`opentorsion.Parser`): components of
  ``Disk``, ``ShaftDiscrete``, ``ShaftContinuous`` and ``GearElement`` elements.
  :func:`read_tors` reads one with openTorsion's parser and executes nothing;
  :func:`write_tors` writes an assembly in it (TORS holds a subset of openTorsion: no
  spring to ground, no elastic mesh, no damping on a shaft with own inertia, a line
  numbered along its links; anything else is refused by name).

:func:`write_model_file` writes any assembly as a Python model file. openTorsion is
optional: imported only by :func:`import_opentorsion`, when a model is read or written.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import json
import math
import sys
import traceback
from pathlib import Path
from typing import Any

from gbpipe.errors import ConfigError

__all__ = ["import_opentorsion", "load_model_file", "read_tors", "write_tors",
           "write_model_file"]


def import_opentorsion(field: str) -> Any:
    """The ``opentorsion`` module, or a ConfigError on ``field`` naming the extra."""
    try:
        import opentorsion  # optional dependency
    except ImportError:
        raise ConfigError(field, "needs openTorsion, which is not installed: "
                          "pip install gbpipe[opentorsion]") from None
    return opentorsion


def _resolve(path_s: str, base: str | Path, field: str) -> Path:
    path = Path(path_s)
    path = path if path.is_absolute() else Path(base) / path
    if not path.is_file():
        raise ConfigError(field, f"file {path} does not exist (a relative path is taken "
                          f"from {Path(base).resolve()})")
    return path


def _local(file: str | None, folder: Path, local: set[str]) -> bool:
    """Whether ``file`` is the model's or one of its helpers': a module or package beside
    it (not any file below the folder: a virtual environment may live there)."""
    if not file:
        return False
    rel = Path(file).resolve()
    if not rel.is_relative_to(folder):
        return False
    return Path(rel.relative_to(folder).parts[0]).stem in local


def _where(exc: BaseException, folder: Path, local: set[str]) -> str:
    """``file:line`` of the deepest frame of the traceback in the model or its helpers."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if _local(f.filename, folder, local)]
    return f"{frames[-1].filename}:{frames[-1].lineno}" if frames else "?"


def load_model_file(spec: str, base: str | Path = ".", field: str = "drivetrain.opentorsion"
                    ) -> tuple[Any, str]:
    """Run ``path.py:function`` as a script and return the assembly it builds.

    Parameters
    ----------
    spec : str
        ``path/to/file.py:function``; a relative path is taken from ``base``.
    base : path-like, default the working directory
        Folder of relative paths.
    field : str
        Key path named in errors.

    Returns
    -------
    opentorsion.Assembly, str
        The assembly and the SHA-256 (hex) of the file, then of each helper it imported
        from its folder (path and bytes, in path order): the file's own hash when it
        imports none.

    Raises
    ------
    ConfigError
        Not ``file:function``; the file missing; a syntax error (file and line); the file
        or the function failing (the error and the deepest line of the model's folder);
        no such function (the spec, the functions there are); a result that is not an
        ``opentorsion.Assembly`` (the function's ``def`` line); openTorsion not installed.
    """
    path_s, sep, func = str(spec).rpartition(":")
    if not sep or not path_s or not func.isidentifier():
        raise ConfigError(field, f"{spec!r} is not 'path/to/file.py:function'")
    ot = import_opentorsion(field)
    path = _resolve(path_s, base, field)
    data = path.read_bytes()
    folder = path.resolve().parent
    name = f"_gbpipe_ot_{path.stem}"
    # a module of the same name imported earlier from elsewhere (another package's
    # `utils`) would shadow the model's own helper: hidden while the model runs
    local = {f.stem for f in folder.glob("*.py")} | {
        d.name for d in folder.iterdir() if (d / "__init__.py").is_file()}
    hidden = {m: sys.modules.pop(m) for m in local & set(sys.modules)
              if not _local(getattr(sys.modules[m], "__file__", None), folder, local)}
    before = set(sys.modules)
    sys.path.insert(0, str(folder))
    try:
        mod_spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(mod_spec)
        sys.modules[name] = module        # what dataclasses and pickling look up
        try:
            mod_spec.loader.exec_module(module)
        except SyntaxError as exc:
            raise ConfigError(field, f"{exc.filename}:{exc.lineno}: syntax error "
                              f"({exc.msg}); fix the file") from None
        except Exception as exc:
            raise ConfigError(field, f"running {path} failed at {_where(exc, folder, local)}: "
                              f"{type(exc).__name__}: {exc}") from exc
        build = getattr(module, func, None)
        if not callable(build):
            have = sorted(n for n, v in vars(module).items()
                          if inspect.isfunction(v) and not n.startswith("_"))
            raise ConfigError(field, f"{spec!r}: {path} has no function {func!r}; it has "
                              f"{have}")
        try:
            assembly = build()
        except Exception as exc:
            raise ConfigError(field, f"{path}:{func}() failed at "
                              f"{_where(exc, folder, local)}: "
                              f"{type(exc).__name__}: {exc}") from exc
    finally:
        if str(folder) in sys.path:
            sys.path.remove(str(folder))
        # the model's own modules (its name, its helpers) are forgotten: a second model
        # with its own utils.py must not get this one's
        helpers = []
        for mod in set(sys.modules) - before:
            file = getattr(sys.modules[mod], "__file__", None)
            if mod == name or (mod.split(".")[0] in local and _local(file, folder, local)):
                del sys.modules[mod]
                if mod != name and file:
                    helpers.append(Path(file).resolve())
        sys.modules.update(hidden)
    if not isinstance(assembly, ot.Assembly):
        code = getattr(inspect.unwrap(build), "__code__", None)
        line = code.co_firstlineno if code is not None else "?"
        raise ConfigError(field, f"{path}:{line}: {func}() returned "
                          f"{type(assembly).__name__}, not an opentorsion.Assembly")
    # the helpers the model imported are part of it: a changed utils.py reruns the rules
    digest = hashlib.sha256(data)
    for file in sorted(helpers):
        digest.update(file.relative_to(folder).as_posix().encode())
        digest.update(file.read_bytes())
    return assembly, digest.hexdigest()


def read_tors(path_s: str | Path, base: str | Path = ".",
              field: str = "drivetrain.opentorsion") -> tuple[Any, str]:
    """Read a TORS JSON model with openTorsion's own parser (nothing is executed).

    Excitations on its elements are load cases, not elements: they are not read (gbpipe's
    excitation is the campaign's).

    Returns
    -------
    opentorsion.Assembly, str
        The assembly and the SHA-256 of the file (hex).

    Raises
    ------
    ConfigError
        The file missing; not JSON (the line); not a TORS model (what the parser
        missed); openTorsion not installed.
    """
    ot = import_opentorsion(field)
    path = _resolve(str(path_s), base, field)
    data = path.read_bytes()
    try:
        tors = json.loads(data)
    except json.JSONDecodeError as exc:
        raise ConfigError(field, f"{path}:{exc.lineno}: not JSON ({exc.msg})") from None
    try:
        assembly, _ = ot.Parser.from_tors(tors)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise ConfigError(field, f"{path} is not a TORS model openTorsion reads: "
                          f"{type(exc).__name__}: {exc}") from None
    return assembly, hashlib.sha256(data).hexdigest()


def _refuse(field: str, what: str) -> ConfigError:
    return ConfigError(field, f"{what}: the TORS format cannot hold it; export a Python "
                       "model file (out.py) instead")


def _shaft_entry(ot: Any, shaft: Any, name: str, field: str) -> dict[str, Any]:
    """A TORS shaft: discrete (k, c), or continuous when it has own inertia."""
    if not shaft.mass:
        return {"name": name, "type": "ShaftDiscrete", "stiffness": float(shaft.k),
                "damping": float(shaft.c)}
    if shaft.c:
        raise _refuse(field, f"shaft {shaft.nl}-{shaft.nr} has own inertia and damping "
                      "(a TORS ShaftContinuous has no damping)")
    # TORS gives a continuous shaft by geometry and density, its shear modulus
    # openTorsion's default: a solid 1 m shaft of the stiffness and mass given
    g = float(inspect.signature(ot.Shaft).parameters["G"].default)
    length = 1.0                                       # [m]
    polar = float(shaft.k) * length / g                # J_p [m⁴]
    return {"name": name, "type": "ShaftContinuous", "length": length * 1e3,
            "outerDiameter": (32.0 * polar / math.pi) ** 0.25 * 1e3, "innerDiameter": 0.0,
            "density": 6.0 * float(shaft.mass) / (polar * length)}


def write_tors(assembly: Any, path: str | Path, name: str = "drivetrain",
               field: str = "drivetrain") -> None:
    """Write an assembly as a TORS JSON model (one component).

    TORS numbers nodes along its elements: node ``k`` must be reached from node ``k−1``
    by a shaft, or by a gear whose parent is an earlier gear. Disks on one node are
    written as one (inertias and dampings summed); a gear's size is written as its
    ``diameter`` ``2·R``.

    Raises
    ------
    ConfigError
        What TORS cannot hold, named: a spring to ground (a Disk's ``k``), an
        ``ElasticGear``, a shaft with own inertia and damping, a node not reached in
        order (a branch of shafts, a loop).
    """
    ot = import_opentorsion(field)
    if assembly.elastic_gear_elements:
        raise _refuse(field, "the assembly has an elastic gear mesh")
    disks: dict[int, list[float]] = {}
    for d in assembly.disk_elements or []:
        if d.k:
            raise _refuse(field, f"the Disk on node {d.node} has a spring to ground "
                          f"(k = {d.k} N·m/rad)")
        acc = disks.setdefault(d.node, [0.0, 0.0])
        acc[0] += float(d.I)
        acc[1] += float(d.c)
    shafts = {(min(s.nl, s.nr), max(s.nl, s.nr)): s for s in assembly.shaft_elements}
    gears = {g.node: g for g in assembly.gear_elements or []}
    elements: list[dict[str, Any]] = []
    for k in range(assembly.dofs):
        gear = gears.get(k)
        child = gear is not None and gear.parent is not None
        if k and (k - 1, k) in shafts and not child:
            elements.append(_shaft_entry(ot, shafts.pop((k - 1, k)), f"shaft{k - 1}", field))
        elif not (k and child and gear.parent.node < k and (k - 1, k) not in shafts):
            if k or child:
                raise _refuse(field, f"node {k} is not reached from node {k - 1} by one "
                              "shaft or by a mesh with an earlier gear (TORS numbers the "
                              "nodes along a line)")
        if gear is not None:
            entry = {"name": f"gear{k}", "type": "GearElement", "inertia": float(gear.I),
                     "diameter": 2.0 * float(gear.R)}
            if child:
                entry["parent"] = f"gear{gear.parent.node}"
            elements.append(entry)
        if k in disks:
            elements.append({"name": f"disk{k}", "type": "Disk", "inertia": disks[k][0],
                             "damping": disks[k][1]})
    if shafts:
        raise _refuse(field, f"the shafts {sorted(shafts)} do not join consecutive nodes")
    tors = {"name": name, "components": [{"name": name, "elements": elements}],
            "structure": []}
    Path(path).write_text(json.dumps(tors, indent=2) + "\n")


def write_model_file(assembly: Any, path: str | Path, function: str = "assembly") -> None:
    """Write an assembly as a Python model file: ``path.py:function`` rebuilds it.

    Every number is written by ``repr`` (the float exactly); every element kind of
    openTorsion 0.3 (Disk with ``c``, ``k``; Shaft by ``k``, ``I``, ``c``; Gear;
    ElasticGear).
    """
    lines = ['"""An openTorsion assembly written by gbpipe (python -m gbpipe '
             'export-opentorsion)."""', "", "import opentorsion as ot", "", "",
             f"def {function}():"]
    lines.append("    disks = [")
    lines += [f"        ot.Disk({d.node}, I={float(d.I)!r}, c={float(d.c)!r}, "
              f"k={float(d.k)!r})," for d in assembly.disk_elements or []]
    lines.append("    ]")
    lines.append("    shafts = [")
    lines += [f"        ot.Shaft({s.nl}, {s.nr}, k={float(s.k)!r}, I={float(s.mass)!r}, "
              f"c={float(s.c)!r})," for s in assembly.shaft_elements]
    lines.append("    ]")
    def tag(g: Any) -> str:
        return f"{'e' if type(g).__name__ == 'ElasticGear' else 'g'}{g.node}"

    # parents before their children: a child names its parent's variable
    todo, done = [*(assembly.gear_elements or []),
                  *(assembly.elastic_gear_elements or [])], set()
    while todo:
        g = next(g for g in todo if g.parent is None or tag(g.parent) in done)
        todo.remove(g)
        done.add(tag(g))
        extra = (f", k={float(g.k)!r}, c={float(g.c)!r}"
                 if type(g).__name__ == "ElasticGear" and g.parent is not None else "")
        parent = "" if g.parent is None else f", parent={tag(g.parent)}"
        lines.append(f"    {tag(g)} = ot.{type(g).__name__}({g.node}, I={float(g.I)!r}, "
                     f"R={float(g.R)!r}{extra}{parent})")
    gear_list = ", ".join(tag(g) for g in assembly.gear_elements or [])
    elastic_list = ", ".join(tag(g) for g in assembly.elastic_gear_elements or [])
    lines.append(f"    return ot.Assembly(shafts, disk_elements=disks, "
                 f"gear_elements=[{gear_list}] or None, "
                 f"elastic_gear_elements=[{elastic_list}] or None)")
    Path(path).write_text("\n".join(lines) + "\n")

