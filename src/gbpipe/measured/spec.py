"""The ``measured:`` mapping of one record, checked before any file is opened.

:func:`parse` turns one entry of the config's ``measured:`` mapping into frozen
dataclasses. Every key is checked against the keys this reader knows, so a typo
(``chanel:``) is refused with the key path and the closest valid key, instead of being
silently ignored. The format is described in ``docs/measured.md``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gbpipe.errors import ConfigError

__all__ = ["FileSpec", "SignalSpec", "RecordSpec", "parse", "GAP_POLICIES", "CHECKS",
           "LEVELS", "default_checks"]

GAP_POLICIES = ("refuse", "split")
_RECORD_KEYS = ("files", "sample_rate", "signals", "gaps", "orders", "validation", "group")
_FILE_KEYS = ("path", "format", "time", "sample_rate", "delimiter", "decimal", "header",
              "time_unit", "interleaved")
_SIGNAL_KEYS = ("file", "channel", "unit", "scale", "offset", "quantity", "pulses_per_rev",
                "threshold", "hysteresis", "edge", "range", "tacho", "checks", "shaft_order")
#: ``setpoint``: a value that is held between updates (set-points, slowly updated drive
#: readings), where long constant stretches are normal
_QUANTITIES = ("value", "setpoint", "angle", "tacho")
_TACHO_KINDS = ("analog", "count", "angle")
#: the checks of a channel's values that ``checks:`` sets, and their levels
CHECKS = ("flat_top", "range")
LEVELS = ("off", "warn", "error")


def default_checks(quantity: str) -> dict[str, str]:
    """The level of each value check for a signal of ``quantity``.

    A flat top is only a hint of clipping (a set-point or a held reading sits at its
    extreme legitimately, an encoder angle rests when the shaft stops): a warning for
    values, off for set-points, angles and tachos. A sample beyond the declared
    ``range:`` is clipping for sure: an error.
    """
    flat = "warn" if quantity == "value" else "off"
    return {"flat_top": flat, "range": "error"}


@dataclass(frozen=True)
class FileSpec:
    """One source file: ``path`` and how to read its time base."""

    key: str
    path: str
    format: str | None = None
    time: str | None = None
    sample_rate: float | None = None
    delimiter: str | None = None
    decimal: str = "."
    header: int = 0
    time_unit: str = "s"
    interleaved: tuple[str, ...] | None = None


@dataclass(frozen=True)
class SignalSpec:
    """One record signal and the channel it comes from."""

    name: str
    file: str
    channel: str
    unit: str | None = None
    scale: float = 1.0
    offset: float = 0.0
    quantity: str = "value"
    pulses_per_rev: int | None = None
    threshold: float | None = None
    hysteresis: float | None = None
    edge: str = "rising"
    range: tuple[float, float] | None = None
    tacho: str = "analog"
    checks: Mapping[str, str] | None = None
    #: a speed (or an encoder angle) of a shaft turning at this multiple of the shaft
    #: the record's ``orders`` refer to [-] (docs/modal.md); None: not a shaft speed
    shaft_order: float | None = None

    def __post_init__(self) -> None:
        if self.checks is None:
            object.__setattr__(self, "checks", default_checks(self.quantity))


@dataclass(frozen=True)
class RecordSpec:
    """One record: its files, signals, grid rate and gap policy."""

    name: str
    files: dict[str, FileSpec]
    signals: dict[str, SignalSpec]
    sample_rate: float
    gaps: str = "refuse"
    interpolate_upto: int = 0
    #: excitation orders of the tacho shaft (docs/modal.md): their lines are not modes
    orders: tuple[float, ...] = ()
    #: held-out window ``(start, end)`` [s] of the identification (None: from the data)
    validation: tuple[float, float] | None = None
    #: name shared by the repeats of one test, identified pooled (None: alone)
    group: str | None = None

    @property
    def speeds(self) -> dict[str, float]:
        """Signals that measure a shaft's speed -> their ``shaft_order`` [-]."""
        return {n: s.shaft_order for n, s in self.signals.items()
                if s.shaft_order is not None}


def _unknown(field: str, key: str, valid: tuple[str, ...]) -> ConfigError:
    close = difflib.get_close_matches(key, valid, n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return ConfigError(f"{field}.{key}", f"unknown key{hint} Valid keys: {', '.join(valid)}")


def _mapping(value: Any, field: str, valid: tuple[str, ...]) -> Mapping:
    if not isinstance(value, Mapping):
        raise ConfigError(field, f"must be a mapping; got {type(value).__name__}")
    for key in value:
        if key not in valid:
            raise _unknown(field, str(key), valid)
    return value


def _positive(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise ConfigError(field, f"must be a positive number [Hz]; got {value!r}")
    return float(value)


def _number(value: Any, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(field, f"must be a number; got {value!r}")
    return float(value)


def _file(key: str, value: Any, field: str) -> FileSpec:
    if isinstance(value, str):
        value = {"path": value}
    m = _mapping(value, field, _FILE_KEYS)
    if "path" not in m:
        raise ConfigError(f"{field}.path", "missing: give the file's path")
    rate = m.get("sample_rate")
    return FileSpec(
        key=key, path=str(m["path"]), format=m.get("format"), time=m.get("time"),
        sample_rate=None if rate is None else _positive(rate, f"{field}.sample_rate"),
        delimiter=m.get("delimiter"), decimal=str(m.get("decimal", ".")),
        header=_count(m.get("header", 0), f"{field}.header"),
        time_unit=str(m.get("time_unit", "s")),
        interleaved=_columns(m.get("interleaved"), f"{field}.interleaved"))


def _columns(value: Any, field: str) -> tuple[str, ...] | None:
    """The column names of an ``interleaved:`` file: at least two, distinct."""
    if value is None:
        return None
    if (not isinstance(value, list | tuple) or len(value) < 2
            or len({str(v) for v in value}) != len(value)):
        raise ConfigError(field, f"must list the file's column names in their order "
                          f"(at least two, distinct); got {value!r}")
    return tuple(str(v) for v in value)


def _checks(value: Any, field: str, quantity: str) -> dict[str, str]:
    """The signal's check levels: the defaults of its quantity, changed by ``checks:``."""
    levels = default_checks(quantity)
    if value is None:
        return levels
    for key, level in _mapping(value, field, CHECKS).items():
        if level not in LEVELS:
            raise ConfigError(f"{field}.{key}", f"must be one of {', '.join(LEVELS)}; "
                              f"got {level!r}")
        levels[key] = level
    return levels


def _count(value: Any, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError(field, f"must be a row number >= 0; got {value!r}")
    return value


def _signal(name: str, value: Any, field: str, files: Mapping[str, FileSpec]) -> SignalSpec:
    m = _mapping(value, field, _SIGNAL_KEYS)
    for key in ("file", "channel"):
        if key not in m:
            raise ConfigError(f"{field}.{key}", f"missing: give the source {key}")
    if m["file"] not in files:
        close = difflib.get_close_matches(str(m["file"]), list(files), n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        raise ConfigError(f"{field}.file", f"'{m['file']}' is not a key of files{hint} "
                          f"Files: {', '.join(files)}")
    quantity = m.get("quantity", "value")
    if quantity not in _QUANTITIES:
        raise _unknown(f"{field}.quantity", str(quantity), _QUANTITIES)
    ppr = m.get("pulses_per_rev")
    if quantity == "tacho":
        if isinstance(ppr, bool) or not isinstance(ppr, int) or ppr < 1:
            raise ConfigError(f"{field}.pulses_per_rev",
                              f"a tacho needs a positive integer pulses_per_rev; got {ppr!r}")
    rng = m.get("range")
    if rng is not None:
        if not (isinstance(rng, list | tuple) and len(rng) == 2 and rng[0] < rng[1]):
            raise ConfigError(f"{field}.range", f"must be [low, high]; got {rng!r}")
        rng = (float(rng[0]), float(rng[1]))
    edge = m.get("edge", "rising")
    if edge not in ("rising", "falling"):
        raise ConfigError(f"{field}.edge", f"must be 'rising' or 'falling'; got {edge!r}")
    tacho = m.get("tacho", "analog")
    if tacho not in _TACHO_KINDS:
        raise ConfigError(f"{field}.tacho", f"must be one of {', '.join(_TACHO_KINDS)}; "
                          f"got {tacho!r}")
    opt = {k: _number(m[k], f"{field}.{k}") for k in ("threshold", "hysteresis") if k in m}
    if "shaft_order" in m:
        if quantity not in ("value", "angle"):
            raise ConfigError(f"{field}.shaft_order", f"a {quantity} signal is not a shaft "
                              "speed: give shaft_order to a speed (value in rpm, rad/s...) or "
                              "an encoder angle (quantity: angle)")
        opt["shaft_order"] = _positive_order(m["shaft_order"], f"{field}.shaft_order")
    return SignalSpec(
        name=name, file=str(m["file"]), channel=str(m["channel"]), unit=m.get("unit"),
        scale=_number(m.get("scale", 1.0), f"{field}.scale"),
        offset=_number(m.get("offset", 0.0), f"{field}.offset"), quantity=quantity,
        pulses_per_rev=ppr, edge=edge, range=rng, tacho=tacho,
        checks=_checks(m.get("checks"), f"{field}.checks", quantity), **opt)


def parse(spec: Mapping[str, Any], name: str = "record") -> RecordSpec:
    """Check one entry of ``measured:`` and return it as a :class:`RecordSpec`.

    Parameters
    ----------
    spec : mapping
        The entry: ``files``, ``sample_rate``, ``signals``, optional ``gaps`` and
        ``orders``, and for the identification optional ``validation: {start, end}``
        [s] (held-out window) and ``group`` (repeats of one test, pooled).
    name : str
        Record name, used in the key paths of error messages (``measured.<name>...``).

    Raises
    ------
    gbpipe.errors.ConfigError
        Naming the key path of an unknown, missing or invalid key.
    """
    root = f"measured.{name}"
    m = _mapping(spec, root, _RECORD_KEYS)
    for key in ("files", "sample_rate", "signals"):
        if key not in m:
            raise ConfigError(f"{root}.{key}", "missing")
    files_in = m["files"]
    if not isinstance(files_in, Mapping) or not files_in:
        raise ConfigError(f"{root}.files", "must be a non-empty mapping key -> file")
    files = {str(k): _file(str(k), v, f"{root}.files.{k}") for k, v in files_in.items()}
    sig_in = m["signals"]
    if not isinstance(sig_in, Mapping) or not sig_in:
        raise ConfigError(f"{root}.signals", "must be a non-empty mapping signal -> source")
    signals = {str(k): _signal(str(k), v, f"{root}.signals.{k}", files)
               for k, v in sig_in.items()}
    gaps, upto = m.get("gaps", "refuse"), 0
    if isinstance(gaps, Mapping):
        _mapping(gaps, f"{root}.gaps", ("interpolate_upto",))
        upto = gaps.get("interpolate_upto")
        if isinstance(upto, bool) or not isinstance(upto, int) or upto < 1:
            raise ConfigError(f"{root}.gaps.interpolate_upto",
                              f"must be a positive number of samples; got {upto!r}")
        gaps = "interpolate"
    elif gaps not in GAP_POLICIES:
        raise ConfigError(f"{root}.gaps", f"must be refuse, split or "
                          f"{{interpolate_upto: N}}; got {gaps!r}")
    orders = m.get("orders", [])
    if not isinstance(orders, list) or not all(
            isinstance(k, int | float) and not isinstance(k, bool) and 0 < k < math.inf
            for k in orders):
        raise ConfigError(f"{root}.orders", f"must be a list of positive shaft orders of "
                          f"the tacho shaft [-] (e.g. [23, 46]); got {orders!r}")
    return RecordSpec(name=name, files=files, signals=signals,
                      sample_rate=_positive(m["sample_rate"], f"{root}.sample_rate"),
                      gaps=gaps, interpolate_upto=upto,
                      orders=tuple(float(k) for k in orders),
                      validation=_window(m.get("validation"), f"{root}.validation"),
                      group=_group(m.get("group"), f"{root}.group"))


def _positive_order(value: Any, field: str) -> float:
    # a shaft's speed relative to the reference shaft: a finite positive ratio
    if (isinstance(value, bool) or not isinstance(value, int | float)
            or not 0 < value < math.inf):
        raise ConfigError(field, f"must be a positive number: the shaft's speed over the "
                          f"reference shaft's (1 for the shaft the orders refer to) [-]; "
                          f"got {value!r}")
    return float(value)


def _window(value: Any, field: str) -> tuple[float, float] | None:
    # the identification's held-out window {start, end} [s from the record start]
    if value is None:
        return None
    m = _mapping(value, field, ("start", "end"))
    if set(m) != {"start", "end"}:
        raise ConfigError(field, "needs both start and end [s from the record start]")
    start, end = _number(m["start"], f"{field}.start"), _number(m["end"], f"{field}.end")
    if not 0 <= start < end:
        raise ConfigError(field, f"needs 0 <= start < end [s]; got {start:g}-{end:g}")
    return start, end


def _group(value: Any, field: str) -> str | None:
    # records of one test share a group name and are identified together
    if value is None:
        return None
    if not isinstance(value, str) or not value.replace("_", "").isalnum():
        raise ConfigError(field, f"must be a name of letters, digits and _; got {value!r}")
    return value
