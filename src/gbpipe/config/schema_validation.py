"""The closed JSON schema of the configuration, with its defaults applied at validation.

:func:`apply_schema` checks a configuration against ``schemas/config.schema.yaml`` and
fills in every ``default:`` of the schema on the way, so that the configuration is complete
afterwards: library code reads ``cfg["tsa"]["unbiased"]`` without a fallback. Every number
is also checked finite first: YAML reads ``.nan`` and ``.inf`` as floats, and NaN compares
false with every bound, so a range check alone would let it through.

The first error is raised as :class:`gbpipe.errors.ConfigError` naming the key path
(``gearbox.stages[1].ring``), the value, and what would be valid; an unknown key (a typo:
every object of the schema is closed) names the closest valid key.
"""

from __future__ import annotations

import copy
import difflib
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any

import jsonschema
import yaml

from gbpipe.errors import ConfigError

__all__ = ["SCHEMA_PATH", "schema", "apply_schema", "key_path", "suggest"]

#: The schema file (``workflow/schemas/config.schema.yaml`` links to it).
SCHEMA_PATH = Path(__file__).resolve().parents[1] / "schemas" / "config.schema.yaml"

_FLOAT_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)[eE][+-]?\d+$")


@cache
def _schema() -> dict[str, Any]:
    with open(SCHEMA_PATH) as fh:
        return yaml.safe_load(fh)


def schema() -> dict[str, Any]:
    """The JSON schema of the configuration, as a dict (a copy: callers may modify it)."""
    return copy.deepcopy(_schema())


def key_path(parts: Sequence[str | int]) -> str:
    """Dotted key path of a config value: ``("gearbox", "stages", 1, "ring")`` ->
    ``"gearbox.stages[1].ring"``."""
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def suggest(word: str, valid: Sequence[str]) -> str:
    """Text naming the valid choices, led by the closest one to ``word`` if any is close."""
    close = difflib.get_close_matches(str(word), list(valid), n=1, cutoff=0.6)
    hint = f"did you mean '{close[0]}'? " if close else ""
    return f"{hint}valid: {', '.join(sorted(valid))}"


def _set_defaults(validator, properties, instance, schema_):
    # Fill the declared defaults before the properties are validated, so that nested
    # objects created from a default ({}) get their own defaults filled in turn.
    if isinstance(instance, dict):
        for name, sub in properties.items():
            if isinstance(sub, Mapping) and "default" in sub and name not in instance:
                instance[name] = copy.deepcopy(sub["default"])
    yield from _PROPERTIES(validator, properties, instance, schema_)


_PROPERTIES = jsonschema.Draft202012Validator.VALIDATORS["properties"]
_Validator = jsonschema.validators.extend(jsonschema.Draft202012Validator,
                                          {"properties": _set_defaults})


def _coerce_numbers(value: Any) -> Any:
    # PyYAML (YAML 1.1) reads 1.5e8 (no dot, no sign in the exponent) as text. Accept
    # exactly that spelling as a number; any other text stays text and fails validation.
    if isinstance(value, str) and _FLOAT_RE.match(value.strip()):
        return float(value)
    if isinstance(value, Mapping):
        return {k: _coerce_numbers(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_coerce_numbers(v) for v in value]
    return value


def _numbers(value: Any, path: tuple) -> Iterator[tuple[tuple, float]]:
    if isinstance(value, float):
        yield path, value
    elif isinstance(value, Mapping):
        for k, v in value.items():
            yield from _numbers(v, (*path, k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _numbers(v, (*path, i))


def _check_finite(cfg: Mapping[str, Any]) -> None:
    for path, x in _numbers(cfg, ()):
        if not math.isfinite(x):
            raise ConfigError(key_path(path), f"{x} is not a finite number; give a finite "
                              "value in the unit of this key (config/README.md)")


def _rank(err: jsonschema.ValidationError) -> tuple:
    # An unknown key comes first: it is usually a misspelt known key, which then also
    # shows up as missing. Then the deepest error (the most specific place).
    return (err.validator != "additionalProperties", -len(err.absolute_path))


_BOUND_TEXT = {"minimum": ">= {}", "exclusiveMinimum": "> {}", "maximum": "<= {}",
               "exclusiveMaximum": "< {}"}


def _bounds(sub: Mapping[str, Any]) -> str:
    return " and ".join(_BOUND_TEXT[k].format(f"{sub[k]:g}") for k in _BOUND_TEXT if k in sub)


def _describe(sub: Mapping[str, Any]) -> str:
    if "const" in sub:
        return repr(sub["const"])
    kind = {"object": "a mapping", "integer": "an integer"}.get(sub.get("type"),
                                                              f"a {sub.get('type', 'value')}")
    bounds = _bounds(sub)
    return f"{kind} {bounds}" if bounds else kind


def _raise(err: jsonschema.ValidationError) -> None:
    path = list(err.absolute_path)
    where = key_path(path)
    sub = err.schema if isinstance(err.schema, Mapping) else {}
    desc = str(sub.get("description", "")).strip()
    hint = f" ({desc})" if desc else ""
    value = err.instance
    if err.validator == "additionalProperties":
        known = list(sub.get("properties", {}))
        extra = sorted(set(value) - set(known), key=str)
        bad = extra[0] if extra else "?"
        raise ConfigError(key_path([*path, bad]), f"unknown key '{bad}'; {suggest(bad, known)}")
    if err.validator == "required":
        missing = err.message.split("'")[1] if "'" in err.message else err.message
        raise ConfigError(key_path([*path, missing]),
                          "is missing: add it (see config/README.md)")
    if err.validator == "enum":
        raise ConfigError(where, f"{value!r} is not valid; "
                          f"{suggest(str(value), [str(v) for v in err.validator_value])}")
    if err.validator == "oneOf":
        # e.g. an inertia given as text "6730 kg m2": the oneOf message says nothing useful
        alternatives = " or ".join(_describe(b) for b in err.validator_value)
        raise ConfigError(where, f"{value!r} is not valid{hint}: expected {alternatives} "
                          "(units are fixed by the key, not written in the value)")
    if err.validator in _BOUND_TEXT:
        raise ConfigError(where, f"{value!r} is out of range: valid values are "
                          f"{_bounds(sub)}{hint}")
    raise ConfigError(where, f"{err.message}{hint}")


def apply_schema(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """Validate ``cfg`` against the schema; return a copy with every default filled in.

    Parameters
    ----------
    cfg : mapping
        A merged configuration (e.g. ``config.yaml`` plus overlays).

    Returns
    -------
    dict
        A new dict: numbers written ``1.5e8`` converted from text, defaults applied.

    Raises
    ------
    ConfigError
        For the first problem: a non-finite number, an unknown key (with the closest valid
        one), a missing key, a wrong type or a value out of its range.
    """
    out = _coerce_numbers(copy.deepcopy(dict(cfg)))
    _check_finite(out)
    errors = list(_Validator(_schema()).iter_errors(out))
    if errors:
        _raise(min(errors, key=_rank))
    return out
