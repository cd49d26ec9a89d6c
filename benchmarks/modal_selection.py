"""Modal selection on random geared chains: gbpipe's modes stage against pyOMA2 (sdypy-EMA).

Cases (``tests/identify/modal_cases.py``, every draw from ``numpy.random.default_rng``
seeded by ``--seed`` and the case number): a random openTorsion chain (4-12 disks, 1-3
gear stages, modal damping 0.5-10 %, every mode in 5-400 Hz, no two closer than twice
the resolution), simulated exactly (zero-order hold, ``scipy.signal.dlsim``) at 2 kHz for
``--duration`` s (default 40 s: 39 half-overlapping Welch segments of 2 s, the
resolution 0.5 Hz holding ten periods of the lowest possible mode, 5 Hz, per segment);
excited by a band-limited (5-60 Hz to 150-350 Hz), in half the cases notched, random
motor torque, plus 3-8 angle-locked order lines of a random shaft (an unmeasured torque)
and coloured sensor noise; outputs a torque meter and a speed. Half the cases carry a
tacho (pulse train of the order lines' shaft), a quarter only its encoder angle, a
quarter no speed. Each is written as a CSV bench file and read back by
``gbpipe.measured.read`` with its ``measured:`` mapping.

Truth: openTorsion's ``modal_analysis`` of the damped chain (gbpipe's own import,
``from_assembly`` + ``build_chain``, is checked against it: the worst relative
difference of the undamped frequencies is printed).

Coherent band: the frequencies in ``identify.frf`` ``f_min``-``f_max`` (5-350 Hz) where the
record's coherence (``scipy.signal.coherence``, Hann segments of
``identify.nonparametric.segment``, 50 % overlap) from the measured motor torque to at
least one output reaches ``identify.nonparametric.coherence_min`` (0.6). A truth mode is
asked of the data (counts for recall) when its frequency lies in it.

Scoring, the same for every tool, on the rows in 5-350 Hz:

* a row matches the truth mode nearest it (relative to that mode's tolerance) when within
  the tolerance ``max(2 df, zeta f / 2)``: twice the resolution ``df``, or a quarter of
  the mode's half-power bandwidth ``2 zeta f``; each truth mode takes at most one row
  (the closest), a second is a duplicate;
* recall: truth modes in the coherent band (``asked``) matched by a ``mode`` row; and the
  same over those of them a resonance of the chain's true FRF shows (``shown``: a peak of
  at least 3 dB prominence from the motor torque to an output within the mode's
  tolerance; a mode with little participation at the input or the outputs shows none);
  and over the ``detect``-able ones: modal SNR (the mode's own peak in the output PSD over
  the record's noise PSD there, ``benchmarks/modal_detectability.py``) at least 1;
* precision: ``mode`` rows matching a truth mode (any of the chain's: a real mode is no
  false claim) over all ``mode`` rows; a row labelled ``harmonic`` or ``spurious`` is no
  claim of a mode;
* harmonic share: of the rows on an excited order line (order x the shaft's speed range,
  widened by ``df``) that match no truth mode, the share labelled ``harmonic``;
* modes as harmonic: rows that match a truth mode, lie on no excited order line and are
  labelled ``harmonic`` (a real mode lost to the label);
* damping error: the median of ``|zeta_row / zeta - 1|`` over the coherent modes found
  (each mode's closest row; per diagram, not for the table as a whole, which may hold
  two rows of a mode).

Counts are summed over the cases of a speed class (and over all cases) before dividing.

Tools, in one process on the same record:

* gbpipe: ``gbpipe.identify.record_modes`` with a validated config of the case (the
  pairing motor torque -> torque meter and speed; the case's orders in every class: a
  version that cannot place them without a tacho refuses them, and then gets none; a
  version whose ``record_modes`` takes ``speeds`` gets the encoder's speed signal), its
  two diagrams ``pbsid`` and ``lscf`` scored apart, and the table as a whole
  (``either``: a truth mode either diagram has a ``mode`` row for; the rows of both count
  for precision and lines), one CPU time for both;
* pyOMA2 (1.4.3): SSI-cov on the two outputs (decimated to ``identify.sample_rate`` with
  ``scipy.signal.decimate``, each scaled to unit rms: they are in different units), its
  automatic selection by hierarchical clustering (``quick="hier_avg"``); no labels, so
  every row is a ``mode`` and its harmonic share is 0 by construction;
* sdypy-EMA (0.31.0) has no automatic selection (poles picked on the stability chart in a
  GUI, or nearest given frequencies): not scored, said so in the output.

Each truth mode gbpipe missed is listed with its modal SNR, modal overlap (spacing over
the sum of half-power half-widths), whether the true FRF shows it, and where it was lost
(``modal_detectability.miss_reason``: a row of another kind, no pole at any order, poles
not stable, stable poles but no cluster kept).

Time: CPU [s] per tool over all cases (the machine is shared: wall time is not
comparable); peak traced memory [MiB] (``tracemalloc``, a second untimed run) on the first
``--memory-cases`` cases.

Usage: ``OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/modal_selection.py --random 30
--seed 1`` (peers: ``requirements-bench.txt``); ``--speed none`` (repeatable) runs only the
cases of that speed class (the draws of the others are made and dropped: the same cases);
``--no-peers`` scores gbpipe alone.
"""

from __future__ import annotations

import argparse
import inspect
import logging
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import scipy.signal
from modal_detectability import miss_reason, modal_overlap, modal_snr
from modal_peers import measured, pyoma2_ssicov

from gbpipe.config import load, merge, validate
from gbpipe.errors import DataError, PulseError
from gbpipe.identify import record_modes
from gbpipe.measured import read
from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_io import from_assembly

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.identify import modal_cases  # noqa: E402

#: Welch segment of the identify stage and of the coherence [s] (resolution 0.5 Hz).
SEGMENT = 2.0
#: The pairing of every case: the motor torque to both outputs.
PAIRING = {"name": "Tm_to_M_w", "inputs": ["motor_torque"],
           "outputs": ["torque_meter", "output_speed"]}
#: Kinds that are no claim of a mode (``spurious``: the classification of later versions).
NOT_MODE = ("harmonic", "spurious")
SPEEDS = ("tacho", "encoder", "none")


def case_config(case: modal_cases.Case) -> Any:
    """The validated config of one case: its ``measured:`` entry and the pairing only."""
    return validate(merge(load(ROOT / "config" / "config.yaml"), {
        "measured": {case.name: case.spec}, "spectra": {"signal": "torque_meter"},
        "identify": {"versions": ["raw"], "nonparametric": {"segment": SEGMENT},
                     "pairings": [PAIRING]}}))


def coherent(case: modal_cases.Case, record: Any, s: dict) -> np.ndarray:
    """Mask of the truth modes in the coherent band (module docstring)."""
    fs = float(record.attrs["sample_rate"])
    u = record["motor_torque"].values
    coh = [scipy.signal.coherence(u, record[o].values, fs=fs,
                                  nperseg=int(round(s["nonparametric"]["segment"] * fs)))
           for o in PAIRING["outputs"]]
    f = case.frequency_hz
    at = np.max([np.interp(f, fc, c) for fc, c in coh], axis=0)
    band = (f >= s["frf"]["f_min"]) & (f <= s["frf"]["f_max"])
    return band & (at >= s["nonparametric"]["coherence_min"])


def visible(case: modal_cases.Case, df: float, band: tuple[float, float]) -> np.ndarray:
    """Mask of the truth modes a resonance of the chain's true FRF shows: a peak of at least
    3 dB prominence (from the motor torque to either output, 0.05 Hz grid) within the
    mode's tolerance."""
    a, b, c, _ = case.plant
    f = np.arange(band[0], band[1], 0.05)
    h = np.array([c[:2] @ np.linalg.solve(2j * np.pi * fk * np.eye(len(a)) - a, b[:, 0])
                  for fk in f])
    peaks = np.concatenate([f[scipy.signal.find_peaks(20 * np.log10(np.abs(h[:, k])),
                                                      prominence=3.0)[0]] for k in (0, 1)])
    tol = tolerance(case, df)
    return np.array([np.any(np.abs(peaks - fm) <= t) for fm, t in
                     zip(case.frequency_hz, tol, strict=True)])


def tolerance(case: modal_cases.Case, df: float) -> np.ndarray:
    """Frequency tolerance of each truth mode [Hz]: ``max(2 df, zeta f / 2)``."""
    return np.maximum(2 * df, 0.5 * case.damping * case.frequency_hz)


def score(f_rows: np.ndarray, kinds: np.ndarray, z_rows: np.ndarray, case: modal_cases.Case,
          asked: np.ndarray, shown: np.ndarray, detect: np.ndarray, df: float,
          band: tuple[float, float]
          ) -> tuple[dict[str, int], np.ndarray, np.ndarray, np.ndarray]:
    """Counts of one tool on one case (module docstring); which truth modes a ``mode`` row
    matched; which have a ``mode`` row within their tolerance that matched another; the
    relative damping error of each truth mode's row (NaN where none matched)."""
    keep = (f_rows >= band[0]) & (f_rows <= band[1])
    f_rows, kinds, z_rows = f_rows[keep], kinds[keep], z_rows[keep]
    f_t = case.frequency_hz
    tol = tolerance(case, df)
    is_mode = ~np.isin(kinds, NOT_MODE)
    d = np.abs(f_rows[:, None] - f_t[None, :]) / tol[None, :]
    nearest = np.argmin(d, axis=1) if f_rows.size else np.zeros(0, int)
    hit = d[np.arange(f_rows.size), nearest] <= 1.0
    true_rows = 0
    found = np.zeros(f_t.size, bool)
    damping_error = np.full(f_t.size, np.nan)
    for j in range(f_t.size):  # the closest mode row of each truth mode counts, once
        rows = np.flatnonzero(hit & is_mode & (nearest == j))
        true_rows += rows.size > 0
        found[j] = rows.size > 0
        if found[j]:
            row = rows[np.argmin(d[rows, j])]
            damping_error[j] = abs(z_rows[row] / case.damping[j] - 1)
    lo, hi = case.shaft_hz
    on_line = np.zeros(f_rows.size, bool)
    for k in case.orders:
        on_line |= (f_rows >= k * lo - df) & (f_rows <= k * hi + df)
    # a truth mode's row called harmonic off every order line: a mode lost to the label
    mode_harmonic = hit & ~on_line & (kinds == "harmonic")
    on_line &= ~hit
    near = ((d <= 1.0) & is_mode[:, None]).any(axis=0) & ~found
    return {"asked": int(asked.sum()), "found": int((found & asked).sum()),
            "shown": int((asked & shown).sum()), "found_shown": int((found & asked & shown).sum()),
            "detect": int((asked & detect).sum()),
            "found_detect": int((found & asked & detect).sum()),
            "mode_rows": int(is_mode.sum()), "true_rows": int(true_rows),
            "line_rows": int(on_line.sum()),
            "line_harmonic": int((on_line & (kinds == "harmonic")).sum()),
            "mode_harmonic": int(mode_harmonic.sum())}, found, near, damping_error


def gbpipe_modes(cfg: Any, record: Any, case: modal_cases.Case) -> tuple[Any, bool]:
    """``record_modes`` with the case's orders, and whether they were taken.

    A version whose ``record_modes`` takes ``speeds`` gets the encoder's speed signal
    (shaft order 1: the encoder is on the order lines' shaft). Orders a version cannot
    place (no speed it reads) are refused with a DataError: then it gets none. A tacho the
    stage refuses (a PulseError: a shaft whose vibration swings its speed by more than a
    quarter within a revolution) is dropped, as its user would, and the record read
    without a speed.
    """
    kw = {}
    if case.speed == "encoder" and "speeds" in inspect.signature(record_modes).parameters:
        kw["speeds"] = {modal_cases.ENCODER_SIGNAL: 1.0}
    try:
        return record_modes(cfg, record, case.orders.tolist(), **kw), True
    except PulseError as exc:
        print(f"  {case.name}: the tacho was refused ({exc}); read without it")
        return record_modes(cfg, record.drop_vars("pulse_time"), [], **kw), False
    except DataError:
        return record_modes(cfg, record, [], **kw), False


def peer_outputs(record: Any, q: int) -> np.ndarray:
    """The outputs decimated ``q`` x (zero phase), mean removed, each at unit rms."""
    y = np.column_stack([record[o].values for o in PAIRING["outputs"]])
    y = scipy.signal.decimate(y - y.mean(axis=0), q, axis=0, ftype="fir", zero_phase=True)
    return y / y.std(axis=0)


def run_case(case: modal_cases.Case, folder: Path, memory: bool, peers: bool = True
             ) -> dict[str, Any]:
    """Every tool (gbpipe alone without ``peers``) on one case: the counts per tool, the
    time and memory per tool."""
    rec = read(case.spec, base_dir=modal_cases.write_case(folder, case), name=case.name)
    cfg = case_config(case)
    s = cfg["identify"]
    df = 1.0 / float(s["nonparametric"]["segment"])
    band = (float(s["frf"]["f_min"]), float(s["frf"]["f_max"]))
    asked = coherent(case, rec, s)
    shown = visible(case, df, band)
    fs = float(rec.attrs["sample_rate"])
    snr = modal_snr(case.plant, case.frequency_hz, case.damping, rec["motor_torque"].values,
                    [rec[o].values for o in PAIRING["outputs"]], fs, SEGMENT)
    overlap = modal_overlap(case.frequency_hz, case.damping)
    detect = snr >= 1.0
    tol = tolerance(case, df)
    out: dict[str, Any] = {"counts": {}, "cost": {}, "misses": [], "damping_error": {}}
    (ds, out["orders_taken"]), *cost = measured(lambda: gbpipe_modes(cfg, rec, case), memory)
    out["cost"]["gbpipe (pbsid + lscf)"] = cost
    either = np.zeros(case.frequency_hz.size, bool)
    for method in ds.method.values:
        d = ds.sel({"method": method}).isel(pairing=0)
        ok = np.isfinite(d.mode_frequency.values)
        out["counts"][f"gbpipe {method}"], found, near, err = score(
            d.mode_frequency.values[ok], np.asarray(d.mode_kind.values[ok], dtype=str),
            d.mode_damping.values[ok], case, asked, shown, detect, df, band)
        out["damping_error"][f"gbpipe {method}"] = err[found & asked]
        either |= found
        for j in np.flatnonzero(asked & ~found):
            why = (miss_reason(d, case.frequency_hz[j], tol[j], near[j]) if detect[j] else
                   "modal SNR < 1: not in the record")
            out["misses"].append((case.name, str(method), case.frequency_hz[j],
                                  case.damping[j], snr[j], overlap[j], bool(shown[j]), why))
    # the table as a whole: a truth mode either diagram has a mode row for; its rows are
    # both diagrams' (each a claim)
    rows = [out["counts"][f"gbpipe {m}"] for m in ds.method.values]
    out["counts"]["gbpipe either"] = {
        **{k: sum(r[k] for r in rows) for k in rows[0]}, "asked": int(asked.sum()),
        "found": int((either & asked).sum()), "shown": int((asked & shown).sum()),
        "found_shown": int((either & asked & shown).sum()),
        "detect": int((asked & detect).sum()),
        "found_detect": int((either & asked & detect).sum())}
    fu = build_chain(from_assembly(case.assembly)).mechanism.undamped_frequencies()
    out["import_error"] = float(np.max(np.abs(np.sort(fu) / case.frequency_hz - 1)))
    if not peers:
        return out
    q = int(round(float(rec.attrs["sample_rate"]) / float(s["sample_rate"])))
    y = peer_outputs(rec, q)
    try:
        found, *cost = measured(lambda: pyoma2_ssicov(
            y, q / float(rec.attrs["sample_rate"]), int(s["stabilization"]["orders"][1])),
            memory)
    except Exception as exc:  # a peer's failure is a result (no rows), not the end
        print(f"  {case.name}: pyOMA2 failed: {type(exc).__name__}: {exc}")
        found, cost = [], [np.nan, np.nan, np.nan]
    out["cost"]["pyOMA2 ssi-cov + hier"] = cost
    f_peer, z_peer = (np.array([row[k] for row in found]) for k in (0, 1))
    tool = "pyOMA2 ssi-cov + hier"
    out["counts"][tool], peer_found, _, err = score(
        f_peer, np.full(f_peer.size, "mode"), z_peer, case, asked, shown, detect, df, band)
    out["damping_error"][tool] = err[peer_found & asked]
    return out


def ratio(a: int, b: int) -> str:
    return f"{a / b:6.3f}" if b else "   n/a"


def table(cases: list[modal_cases.Case], results: list[dict[str, Any]]) -> None:
    """The scores per tool and speed class, then the cost per tool."""
    tools = list(results[0]["counts"])
    print(f"\n{'tool':24s} {'speed':8s} {'cases':>5s} {'asked':>5s} {'recall':>6s} "
          f"{'shown':>5s} {'recall':>6s} {'detect':>6s} {'recall':>6s} {'mode rows':>9s} "
          f"{'precision':>9s} {'line rows':>9s} {'harmonic':>8s} {'modes as harmonic':>17s} "
          f"{'damping error':>13s}")
    for tool in tools:
        for cls in (*SPEEDS, "all"):
            rows = [r["counts"][tool] for c, r in zip(cases, results, strict=True)
                    if cls in ("all", c.speed)]
            if not rows:
                continue
            tot = {k: sum(r[k] for r in rows) for k in rows[0]}
            harm = ("     n/a" if tool.startswith("pyOMA2") else
                    f"{ratio(tot['line_harmonic'], tot['line_rows']):>8s}")
            # median relative damping error of the coherent modes found (one row each);
            # the table as a whole has two rows per mode, so none
            errs = np.concatenate([[]] + [r["damping_error"][tool]
                                          for c, r in zip(cases, results, strict=True)
                                          if cls in ("all", c.speed)
                                          and tool in r["damping_error"]])
            err = (f"{np.nanmedian(errs):13.3f}" if np.isfinite(errs).any()
                   else f"{'n/a':>13s}")
            print(f"{tool:24s} {cls:8s} {len(rows):5d} {tot['asked']:5d} "
                  f"{ratio(tot['found'], tot['asked'])} {tot['shown']:5d} "
                  f"{ratio(tot['found_shown'], tot['shown'])} {tot['detect']:6d} "
                  f"{ratio(tot['found_detect'], tot['detect'])} {tot['mode_rows']:9d} "
                  f"{ratio(tot['true_rows'], tot['mode_rows']):>9s} {tot['line_rows']:9d} "
                  f"{harm} {tot['mode_harmonic']:17d} {err}")
    print(f"{'sdypy-EMA lscf':24s} not scored: no automatic selection (select_poles is a "
          "GUI, select_closest_poles needs the frequencies)")
    print(f"\n{'tool':24s} {'cpu total [s]':>13s} {'cpu/case [s]':>12s} "
          f"{'peak [MiB]':>10s}")
    for tool in results[0]["cost"]:
        cpu = np.array([r["cost"][tool][0] for r in results])
        peak = np.array([r["cost"][tool][2] for r in results])
        print(f"{tool:24s} {np.nansum(cpu):13.1f} {np.nanmean(cpu):12.2f} "
              f"{np.nanmax(peak) if np.isfinite(peak).any() else np.nan:10.1f}")


def misses(results: list[dict[str, Any]]) -> None:
    """gbpipe's missed truth modes, one line each: the physics, then where it was lost."""
    rows = [m for r in results for m in r["misses"]]
    print(f"\ngbpipe's misses ({len(rows)}; detectable: modal SNR >= 1; overlap: spacing over "
          "the sum of half-power half-widths; shown: a 3 dB peak of the true FRF)")
    print(f"{'case':7s} {'method':6s} {'f [Hz]':>7s} {'zeta':>6s} {'SNR':>8s} {'overlap':>7s} "
          f"{'shown':>5s} reason")
    for name, method, f, z, snr, ov, shown, why in sorted(rows, key=lambda m: (m[1], m[7])):
        print(f"{name:7s} {method:6s} {f:7.1f} {z:6.3f} {snr:8.2g} {ov:7.2f} {shown!s:>5s} "
              f"{why}")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--random", type=int, default=30, help="number of random cases")
    p.add_argument("--seed", type=int, default=1, help="seed of the cases")
    p.add_argument("--duration", type=float, default=40.0, help="record length [s]")
    p.add_argument("--speed", choices=SPEEDS, action="append",
                   help="run only the cases of this speed class (repeatable; default all)")
    p.add_argument("--no-peers", action="store_true",
                   help="score gbpipe alone (no pyOMA2 run)")
    p.add_argument("--memory-cases", type=int, default=2,
                   help="cases whose peak memory is traced (a second run each)")
    a = p.parse_args(argv)
    logging.disable(logging.WARNING)  # pyOMA2 logs every step
    t0 = time.process_time()
    results, cases = [], []
    with tempfile.TemporaryDirectory() as tmp:
        drawn = modal_cases.cases(a.random, a.seed, duration=a.duration)
        for i, case in enumerate(c for c in drawn if c.speed in (a.speed or SPEEDS)):
            r = run_case(case, Path(tmp), i < a.memory_cases, not a.no_peers)
            cases.append(case)
            results.append(r)
            n = {t: f"{c['found']}/{c['asked']} found, {c['true_rows']}/{c['mode_rows']} "
                 "true" for t, c in r["counts"].items()}
            print(f"{case.name} {case.speed:7s} {case.frequency_hz.size:2d} modes, "
                  f"{len(case.orders)} lines at {case.shaft_hz[0]:.2f} Hz; " +
                  "; ".join(f"{t}: {v}" for t, v in n.items()), flush=True)
    for cls in (a.speed or SPEEDS):
        n = [r["orders_taken"] for c, r in zip(cases, results, strict=True) if c.speed == cls]
        print(f"{cls}: gbpipe took the orders in {sum(n)} of {len(n)} cases")
    print(f"\n{a.random} cases, seed {a.seed}, {a.duration:g} s at 2 kHz; gbpipe "
          f"{Path(record_modes.__code__.co_filename).parents[2]}; worst relative "
          "difference of gbpipe's imported undamped frequencies to openTorsion's: "
          f"{max(r['import_error'] for r in results):.1e}")
    table(cases, results)
    misses(results)
    print(f"\ntotal CPU {time.process_time() - t0:.0f} s")


if __name__ == "__main__":
    main()
