"""Cross-field checks of harmonic removal (``tsa``) and spectra (``spectra``).

Each condition here failed a job only after the sweep or the tests had been simulated:

* a TSA block needs ``n_cycles`` whole cycles inside the record (``quadratic`` a window of
  ``n_cycles`` rounded up to odd); a record spans ``order × revolutions`` cycles of a cycle
  of HSS order ``order``, counted from the speed reference (the tachometer pulses span up
  to two revolutions less: kept as margin);
* ``unbiased`` needs the removed share of the residual below one: ``Σ 1/n_cycles`` over
  the cycles removed jointly (the centre weight of the quadratic fit for ``quadratic``);
* a spectrum frame (``1 / resolution`` seconds, or ``1 / order_resolution`` revolutions)
  must fit in the sweep, and ``overlap`` must leave a hop of at least one sample; the
  frames are held at once, so their count × length is bounded by :data:`MAX_FRAME_BYTES`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from scipy.fft import next_fast_len
from scipy.signal import get_window, savgol_coeffs

from gbpipe.config.schema_validation import suggest
from gbpipe.config.scope import simulated
from gbpipe.errors import ConfigError
from gbpipe.harmonics import excitation_families, family_names, test_families
from gbpipe.identify import VERSIONS
from gbpipe.kinematics import order_of
from gbpipe.simulate import base_test
from gbpipe.simulate.profiles import sweep_revolutions, test_revolutions
from gbpipe.simulate.signals import recorded_signals

__all__ = ["MAX_FRAME_BYTES", "REVOLUTION_MARGIN", "check_tsa", "check_spectra",
           "check_removal"]

#: Largest array of spectrum frames [bytes] (float64): 2 GiB.
MAX_FRAME_BYTES = 2 * 1024**3
#: Revolutions the tachometer pulses may span less than the speed reference.
REVOLUTION_MARGIN = 2.0


def _cycles_needed(n_cycles: int, averaging: str) -> int:
    return n_cycles + (n_cycles % 2 == 0) if averaging == "quadratic" else n_cycles


def _self_weight(n_cycles: int, averaging: str) -> float:
    if averaging == "quadratic":
        window = _cycles_needed(n_cycles, averaging)
        return float(savgol_coeffs(window, 2)[window // 2])
    return 1.0 / n_cycles


def _check_removal(cfg: Mapping[str, Any], field: str, cycles: Sequence[str], averaging: str,
                   revs: float, record: str) -> None:
    tsa = cfg["tsa"]
    n = int(tsa["n_cycles"])
    if averaging == "quadratic" and n < 4:
        raise ConfigError("tsa.n_cycles", f"{n}: averaging 'quadratic' ({field}) fits a "
                          "quadratic across cycles and needs n_cycles >= 4")
    need = _cycles_needed(n, averaging)
    for j, name in enumerate(cycles):
        order = float(order_of(cfg["gearbox"]["stages"], name))
        have = order * (revs - REVOLUTION_MARGIN)
        if have < need:
            raise ConfigError(
                f"{field}[{j}]",
                f"'{name}' (HSS order {order:.4g}): the {record} spans {have:.1f} of its "
                f"cycles but tsa.n_cycles = {n} ({averaging}) needs {need}; lengthen the "
                f"record or lower tsa.n_cycles to {max(2, math.floor(have))}")
    if tsa["unbiased"] and len(cycles) * _self_weight(n, averaging) >= 1:
        raise ConfigError("tsa.unbiased", f"removing {len(cycles)} cycles jointly with "
                          f"n_cycles = {n} ({averaging}) removes all of the residual; "
                          "raise tsa.n_cycles or set unbiased: false")


def check_tsa(cfg: Mapping[str, Any]) -> None:
    """Check that every TSA variant fits the sweep and ``tsa.tests`` the identified tests.

    Only when the campaign is simulated: a bench record's length is known once read,
    and its TSA then names what is missing.
    """
    if not simulated(cfg):
        return
    tsa = cfg["tsa"]
    revs = sweep_revolutions(cfg["sweep"])
    for i, v in enumerate(tsa["variants"]):
        _check_removal(cfg, f"tsa.variants[{i}].cycles", v["cycles"], v["averaging"], revs,
                       "sweep")
    idc = cfg["identify"]
    if "tsa" not in idc["versions"]:
        return
    if not tsa["tests"]:
        raise ConfigError("tsa.tests", "is empty but identify.versions has 'tsa': name the "
                          "cycles to remove (e.g. [hss]) or drop 'tsa' from identify.versions")
    camp = cfg["campaign"]
    # the validation partner of each test has the same length and no fewer revolutions
    # than the lowest-speed record of the identified set
    shortest = min((test_revolutions(camp, base_test(cfg, t), p), t, p)
                   for t in idc["tests"] for p in idc["profiles"])
    _check_removal(cfg, "tsa.tests", tsa["tests"], "block", shortest[0],
                   f"{shortest[1]} ({shortest[2]}) test")


def _check_frames(field: str, n_samples: float, frame: int, overlap: float, what: str,
                  fix: str) -> None:
    if frame > n_samples:
        raise ConfigError(field, f"frames of {frame} samples ({what}) do not fit in the sweep "
                          f"({n_samples:.0f} samples); {fix}")
    hop = frame * (1.0 - overlap)
    if hop < 1.0:
        raise ConfigError("spectra.overlap", f"{overlap:g} leaves a hop of {hop:.3g} samples "
                          f"between frames of {frame} samples ({what}); use overlap <= "
                          f"{1 - 1 / frame:.6g}")
    size = (math.floor((n_samples - frame) / max(1, round(hop))) + 1) * frame * 8
    if size > MAX_FRAME_BYTES:
        raise ConfigError("spectra.overlap", f"{overlap:g} with frames of {frame} samples "
                          f"({what}) needs {size / 1024**3:.1f} GiB of frames (limit "
                          f"{MAX_FRAME_BYTES / 1024**3:.0f} GiB); lower the overlap")


def check_spectra(cfg: Mapping[str, Any]) -> None:
    """Check the spectra settings against the sweep record.

    With bench records only the window (``spectra.signal`` names a mapped signal:
    :mod:`gbpipe.config.measured`; the sweep is not simulated).
    """
    sp, sw = cfg["spectra"], cfg["sweep"]
    try:
        get_window(sp["window"], 16)
    except ValueError as exc:
        raise ConfigError("spectra.window", f"'{sp['window']}' is not a scipy.signal window "
                          f"({exc}); use e.g. hann, hamming, blackman, boxcar") from None
    if not simulated(cfg):
        return
    names = recorded_signals(cfg, "sweep")
    if sp["signal"] not in names:
        raise ConfigError("spectra.signal", f"'{sp['signal']}' is not a sweep signal; "
                          f"{suggest(sp['signal'], names)}")
    fs = float(sw["sample_rate"])
    if sp["max_frequency"] > fs / 2:
        raise ConfigError("spectra.max_frequency", f"{sp['max_frequency']:g} Hz is above the "
                          f"Nyquist frequency of the sweep ({fs / 2:g} Hz)")
    if sp["mode_max_frequency"] > sp["max_frequency"]:
        raise ConfigError("spectra.mode_max_frequency",
                          f"{sp['mode_max_frequency']:g} Hz is above spectra.max_frequency "
                          f"({sp['max_frequency']:g} Hz): those modes are not in the spectra")
    n = (sw["settle"] + sw["duration"]) * fs
    frame = round(fs / sp["resolution"])
    if frame < 4:
        raise ConfigError("spectra.resolution", f"{sp['resolution']:g} Hz gives frames of "
                          f"{frame} samples; use at most {fs / 4:g} Hz")
    _check_frames("spectra.resolution", n, frame, sp["overlap"],
                  f"resolution {sp['resolution']:g} Hz at {fs:g} Hz",
                  f"use a resolution of at least {fs / n:.3g} Hz")
    # order frames: angular resampling at next_fast_len(ceil(2.5 × max_order)) samples per
    # revolution (the max order at 0.4 of it), 1 / order_resolution revolutions per frame
    per_rev = next_fast_len(math.ceil(2.5 * sp["max_order"]))
    revs = sweep_revolutions(sw) - REVOLUTION_MARGIN
    _check_frames("spectra.order_resolution", revs * per_rev,
                  round(per_rev / sp["order_resolution"]), sp["overlap"],
                  f"{1 / sp['order_resolution']:g} revolutions",
                  f"use an order resolution of at least {1 / revs:.3g}")


def check_removal(cfg: Mapping[str, Any]) -> None:
    """Check the ``removal`` section and the identification versions that name a method.

    A version beyond :data:`gbpipe.identify.VERSIONS` is a removal method run on the tests: it
    must be in ``removal.methods``, needs simulated tests (bench records have ``raw`` and
    ``tsa``) and families to remove (those of ``removal.tests``). A per-family
    ``regression.knot_spacing`` may name only the gearbox's families (``shaft``,
    ``mesh<k>``) and ``default``, and needs ``default`` unless it names every excited one.

    Only when the campaign is simulated (bench records have no removal versions:
    :data:`gbpipe.config.scope.BENCH_VERSIONS`).
    """
    if not simulated(cfg):
        return
    rem = cfg["removal"]
    families = excitation_families(cfg)
    # any family the gearbox can have (an unexcited one is simply not removed)
    names = family_names(cfg["gearbox"]["stages"])
    spacing = rem["regression"]["knot_spacing"]
    if isinstance(spacing, Mapping):
        for key in spacing:
            if key != "default" and key not in names:
                raise ConfigError(f"removal.regression.knot_spacing.{key}",
                                  f"is not a family of this gearbox; "
                                  f"{suggest(key, [*names, 'default'])}")
        missing = [f for f in families if f not in spacing]
        if missing and "default" not in spacing:
            raise ConfigError("removal.regression.knot_spacing",
                              f"gives no spacing for the families {missing}: add 'default'")
    methods = [v for v in cfg["identify"]["versions"] if v not in VERSIONS]
    if not methods:
        return
    for m in methods:
        if m not in rem["methods"]:
            raise ConfigError("identify.versions", f"'{m}' is a removal method not in "
                              f"removal.methods {rem['methods']}; add it there or drop it")
    if not test_families(cfg):
        raise ConfigError("removal.tests", f"{cfg['removal']['tests']} removes no excitation "
                          f"family ({sorted(families)}), but identify.versions {methods} "
                          "remove those of removal.tests: name a cycle that carries one "
                          "(e.g. hss)")

