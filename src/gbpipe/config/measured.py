"""Cross-field checks of the ``measured:`` records against the analysis they feed.

Every record mapping is parsed at load (:func:`gbpipe.measured.parse`: unknown keys,
missing fields, bad gap policies), and everything the analysis will ask of the records
that the mapping already tells is checked here, before any file is opened: the pairings
and ``spectra.signal`` name mapped signals (``spectra.signal`` only of records with a
tacho: the spectra against rpm are made of those), TSA has a tachometer, the
identification rate divides each record's rate. A record too short for the
identification windows is refused when it is read (:func:`min_duration` is passed to
the reader).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.config.identification import DECIMATION_TRANSIENT, min_samples
from gbpipe.config.schema_validation import suggest
from gbpipe.config.scope import BENCH_VERSIONS
from gbpipe.errors import ConfigError
from gbpipe.measured import RecordSpec, parse

__all__ = ["check_measured", "measured_specs", "min_duration", "bench_versions"]


def measured_specs(cfg: Mapping[str, Any]) -> dict[str, RecordSpec]:
    """The parsed ``measured:`` records (empty when the campaign is simulated)."""
    return {name: parse(spec, name) for name, spec in cfg["measured"].items()}


def bench_versions(cfg: Mapping[str, Any]) -> list[str]:
    """The versions of ``identify.versions`` that the bench records have, in its order.

    A bench record has ``raw`` and, when a record has a tacho channel on the paper's
    gearbox, ``tsa`` (:data:`gbpipe.config.scope.BENCH_VERSIONS`; TSA removes the cycles
    of ``tsa.tests``, orders of the ``gearbox:`` stages, so not on a described
    ``drivetrain:``); ``clean`` and the removal methods beyond TSA exist only for
    simulated records (the simulator's exact separation). The list of
    ``config/config.yaml`` is the paper campaign's, so the others are left out, not
    refused: a bench config need not name its versions.

    Raises
    ------
    gbpipe.errors.ConfigError
        (``identify.versions``) None of the listed versions is one the records have.
    """
    specs = measured_specs(cfg)
    tacho = any(sg.quantity == "tacho" for spec in specs.values()
                for sg in spec.signals.values())
    tsa = tacho and not cfg.get("drivetrain")
    have = [v for v in BENCH_VERSIONS if v != "tsa" or tsa]
    listed = list(cfg["identify"]["versions"])
    kept = [v for v in listed if v in have]
    if not kept:
        raise ConfigError("identify.versions", f"{listed}: none is a version the bench "
                          f"records have ({have}; tsa needs a signal with quantity: tacho "
                          "and the paper's gearbox, whose orders it removes); list "
                          f"{' or '.join(have)}")
    return kept


def min_duration(cfg: Mapping[str, Any]) -> float:
    """Shortest measured record the identification can use [s].

    The initial steady state (``campaign.settle``), the decimation filter's start-up, and
    enough samples for every method's data matrix in the part that is not held out.
    """
    idc = cfg["identify"]
    channels = max(len(p["inputs"]) + len(p["outputs"]) for p in idc["pairings"])
    need = max(min_samples(m, idc["past"], idc["future"], channels) for m in idc["methods"])
    fit_s = (need + DECIMATION_TRANSIENT) / idc["sample_rate"]
    return float(cfg["campaign"]["settle"]) + fit_s / (1.0 - idc["holdout"])


def _check_signals(cfg: Mapping[str, Any], specs: Mapping[str, RecordSpec]) -> None:
    # every signal the analysis names is a mapped (non-tacho) signal of every record
    named = [(f"identify.pairings[{i}].{key}[{j}]", name)
             for i, p in enumerate(cfg["identify"]["pairings"])
             for key in ("inputs", "outputs", "reference")
             for j, name in enumerate(p.get(key, []))]
    for rec, spec in specs.items():
        values = [n for n, sg in spec.signals.items() if sg.quantity != "tacho"]
        # spectra against rpm are made of the records with a tacho only
        tacho = len(values) < len(spec.signals)
        for field, name in [*named, *([("spectra.signal", cfg["spectra"]["signal"])]
                                      if tacho else [])]:
            if name not in values:
                raise ConfigError(field, f"'{name}' is not a signal of measured.{rec}; "
                                  f"{suggest(name, values)}")


def check_measured(cfg: Mapping[str, Any]) -> None:
    """Check the ``measured:`` records and what the analysis needs of them.

    Raises
    ------
    gbpipe.errors.ConfigError
        Naming the key path (``measured.<record>.…`` or ``identify.…``) and the fix.
    """
    specs = measured_specs(cfg)
    if not specs:
        return
    idc = cfg["identify"]
    _check_signals(cfg, specs)
    for rec, spec in specs.items():  # a group's identify output is named by the group
        if spec.group in specs:
            raise ConfigError(f"measured.{rec}.group", f"'{spec.group}' is also a record's "
                              "name; name the group of repeats differently")
    fs_id = float(idc["sample_rate"])
    for rec, spec in specs.items():
        ratio = spec.sample_rate / fs_id
        if fs_id > spec.sample_rate or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ConfigError(f"measured.{rec}.sample_rate", f"{spec.sample_rate:g} Hz is not "
                              f"an integer multiple of identify.sample_rate ({fs_id:g} Hz)")
        tachos = [n for n, sg in spec.signals.items() if sg.quantity == "tacho"]
        if "tsa" in idc["versions"] and len(tachos) != 1:
            raise ConfigError(f"measured.{rec}.signals", f"version 'tsa' (identify.versions) "
                              "needs exactly one signal with quantity: tacho in every "
                              f"record; found {tachos}: map one, or drop 'tsa'")
    fr = idc["frf"]
    if fr["f_min"] >= fr["f_max"] or fr["f_max"] > idc["lowpass"] * fs_id / 2:
        raise ConfigError("identify.frf.f_max", f"{fr['f_max']:g} Hz must lie above f_min "
                          f"({fr['f_min']:g} Hz) and within the anti-aliasing pass band "
                          f"({idc['lowpass'] * fs_id / 2:g} Hz)")
