"""Config key paths such as ``"gearbox.stiffness[1]"``: read one number, set several.

The fit (:mod:`gbpipe.fit.estimate`) frees parameters named by the same key paths the config
errors print (:class:`gbpipe.errors.ConfigError`). The model layer may not import
:mod:`gbpipe.config`, so the fit works on an already validated config dict and resolves
the paths here: dots between mapping keys, ``[i]`` for a list index.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from functools import lru_cache
from typing import Any

from gbpipe.errors import ConfigError

__all__ = ["parse_path", "get_value", "with_values", "overlay"]

_TOKEN = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


def parse_path(path: str) -> list[str | int]:
    """Split a key path into mapping keys (str) and list indices (int).

    Raises
    ------
    ConfigError
        An empty or malformed path (e.g. ``"gearbox..inertia"``, ``"inertia[x]"``).
    """
    return list(_parse(path))


@lru_cache(maxsize=256)
def _parse(path: str) -> tuple[str | int, ...]:
    # cached: the fit sets the same few paths once per model evaluation
    parts: list[str | int] = []
    pos = 0
    for m in _TOKEN.finditer(path):
        gap = path[pos:m.start()]
        if gap not in ("", ".") or (gap == "." and not parts):
            break
        parts.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        pos = m.end()
    if not parts or pos != len(path):
        raise ConfigError(path, "not a key path: write keys joined by '.' and list "
                                "indices as [i], e.g. 'gearbox.stiffness[1]'")
    return tuple(parts)


def _child(node: Any, key: str | int, path: str) -> Any:
    ok = (isinstance(key, int) and isinstance(node, Sequence) and not isinstance(node, str)
          and key < len(node)) or (isinstance(key, str) and isinstance(node, Mapping)
                                   and key in node)
    if not ok:
        raise ConfigError(path, f"no entry {key!r} here; a free parameter must name a number "
                                "that the validated config holds")
    return node[key]


def get_value(cfg: Mapping[str, Any], path: str) -> float:
    """The number at ``path`` (e.g. ``"bench.coupling.stiffness"`` [N·m/rad]).

    Raises
    ------
    ConfigError
        The path does not exist or does not end at a number.
    """
    node: Any = cfg
    for key in parse_path(path):
        node = _child(node, key, path)
    if isinstance(node, bool) or not isinstance(node, int | float):
        raise ConfigError(path, f"holds {node!r}, not a number: free only numeric "
                                "parameters (e.g. one member of a member-inertia mapping)")
    return float(node)


def with_values(cfg: Mapping[str, Any], values: Mapping[str, float]) -> dict[str, Any]:
    """A copy of ``cfg`` with the numbers at the given key paths replaced.

    Only the containers along the paths are copied (the fit calls this per evaluation);
    the caller's config is never modified.
    """
    out = dict(cfg)
    for path, value in values.items():
        get_value(cfg, path)    # checks the path before anything is copied
        keys = parse_path(path)
        node: Any = out
        for key in keys[:-1]:
            child = node[key]
            node[key] = dict(child) if isinstance(child, Mapping) else list(child)
            node = node[key]
        node[keys[-1]] = float(value)
    return out


def overlay(cfg: Mapping[str, Any], paths: Sequence[str]) -> dict[str, Any]:
    """The nested part of ``cfg`` that holds ``paths``: a config overlay.

    A list is written whole (a config merge replaces lists), so the overlay of
    ``"gearbox.stiffness[1]"`` is ``{"gearbox": {"stiffness": [k1, k2, k3]}}``.
    """
    out: dict[str, Any] = {}
    for path in paths:
        keys = parse_path(path)
        src: Any = cfg
        dst: Any = out
        for i, key in enumerate(keys):
            src = src[key]
            if i == len(keys) - 1 or isinstance(keys[i + 1], int) or not isinstance(
                    src, Mapping):
                dst[key] = _plain(src)
                break
            dst = dst.setdefault(key, {})
    return out


def _plain(node: Any) -> Any:
    if isinstance(node, Mapping):
        return {k: _plain(v) for k, v in node.items()}
    if isinstance(node, list | tuple):
        return [_plain(v) for v in node]
    return node
