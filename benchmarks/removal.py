"""Benchmark of the harmonic-removal methods on the default sweep, with the exact
separation metric (gbpipe.harmonics.separation), and the peer rota-order's Vold-Kalman
filter beside ours.

The sweep is simulated twice through gbpipe's public API (``gbpipe.simulate.sweep``):
as configured, and with every angle-locked excitation amplitude set to zero, the same
seeds otherwise: the random-only record. In ``gbpipe.simulate.campaign`` the motor ripple
and sensor noise come from ``default_rng(SeedSequence(seed, key))`` and are drawn before
and independently of the excitation, whose phases come from their own generator
(``excitation.seed``) and are drawn for every configured order whatever its amplitude;
a zero amplitude only zeroes the excitation input, whose response (a separate linear
simulation from rest) is then exactly zero. So the random-only record is the same noise
realisation, and ``record - random_only`` is exactly the harmonic part
(tests/simulate/test_random_only.py). The script prints how far the two tachometer pulse
trains differ (the excitation moves the HSS angle by micro-radians; every method uses
the pulses of the full record).

Per method: wall-clock time on the record; peak memory traced by :mod:`tracemalloc`
(numpy and scipy allocate through it; LAPACK work arrays are small here) in a second run
on the harmonic part alone, whose residual gives ``leftover_db``; the worst-bin
attenuation of each family [dB] on the harmonic part alone (the issue's target: >= 60 dB
for the best method in every rpm bin) and with the random part (bounded by the random
part's own components at the orders, which any removal takes with them); the worst level
error ``change_db`` and worst ``distortion_db`` over the bands around the bench modes in
every rpm bin (target: |change| <= 1 dB), and ``change_db`` of the rest of the spectrum.

Peer. rota-order (GPL-3.0, https://github.com/ZhenxianLi/ROTA) is never a dependency:
install it outside the repository (``pip install --no-deps --target /tmp/peer
rota-order``) and pass ``--peer /tmp/peer``. Its ``rota.extract.remove_orders`` gets the
per-sample speed from ``gbpipe.harmonics.shaft_speed`` of the same pulses. Without
``--peer`` (or if it fails to import or run), the script says so and compares with the
published VKF figure instead: Vold and Leuridan (SAE 931288, 1993) and Tuma (2005) quote
order-extraction errors of the order of -40 to -60 dB for clean, well-separated orders.

With ``--crossings`` it runs, instead of the default sweep, the crossing sweeps
(``CROSSING_RANGES`` x ``CROSSING_RATES`` x ``CROSSING_SEEDS``): per method and sweep the
worst mode-band level change in a bin where a removed order lies within the half-power
band of a bench mode of that band (``crossing_marks``), the worst anywhere, the worst-bin
leftover per family, wall and CPU time and traced peak; then the worst over all sweeps. Each
sweep line also prints the largest change of the twist between the two HSS ends (GB2 HSS
angle minus GB1 HSS angle, the time integral of the two clean HSS speeds' difference)
after the settle, and the rms error of the tachometer angle against the simulation's true
GB1 HSS angle within 0.6 s of the ramp's start and elsewhere: the lines of gearbox 2 and
of the driver motor are locked to the GB2 HSS angle, the tachometer sits on the GB1 HSS,
and during the speed loop's transient at the start of the ramp their phase against the
tachometer angle moves by ``order x twist``.
The crossing sweeps end with the isolated-crossing limit of the regression's model at
each sweep rate (``benchmarks/removal_bound.py``) beside each method's worst crossing
bin. ``--second-angle none`` runs the regression on the tachometer angle alone (no
``removal.regression.second_angle``).
``--gearboxes gb1`` runs the crossing sweeps with the excitation of gearbox 1 alone
(every gearbox line then locked to the tachometer's shaft; the converters' pulsating
torque as configured): what the removal reads when each gearbox line is referred to its
own shaft's angle.

Run::

    OMP_NUM_THREADS=1 python benchmarks/removal.py [--peer /tmp/peer] [--methods vkf ...]
    OMP_NUM_THREADS=1 python benchmarks/removal.py --crossings [--gearboxes gb1]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
from removal_bound import print_limits

from gbpipe.config import load
from gbpipe.harmonics import (
    crossing_marks,
    excitation_families,
    method_params,
    record_params,
    shaft_angle,
    shaft_speed,
    structural_modes,
)
from gbpipe.harmonics.removal import METHODS
from gbpipe.harmonics.separation import separation_metrics
from gbpipe.harmonics.stage import MODE_MIN_FREQUENCY
from gbpipe.lti import modes
from gbpipe.model import bench_ss
from gbpipe.simulate import random_only, sweep
from gbpipe.units import RPM_PER_RAD_S

ROOT = Path(__file__).resolve().parents[1]

def records(cfg: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, dict, object]:
    """Full and random-only sweep signal, pulses, sample rate, the angle figures
    (:func:`angle_figures`) and the full sweep (its speeds give the regression's second
    angle, as in the workflow); checks the seeds."""
    full = sweep(cfg)
    rnd = sweep(random_only(cfg))
    sig = cfg["spectra"]["signal"]
    # the same draws in both runs: tests/simulate/test_random_only.py (the difference is
    # lines at the excited orders to > 99.9 %; the clean signals differ by the pulsating
    # torque's response, which is angle-locked too)
    dp = np.abs(full.pulse_time.values - rnd.pulse_time.values).max()
    print(f"pulse times of the two runs differ by at most {dp * 1e6:.3f} us")
    x = full[sig].values.astype(float)
    fs = float(full.attrs["sample_rate"])
    return x, rnd[sig].values.astype(float), full.pulse_time.values, fs, angle_figures(
        full, float(cfg["sweep"]["settle"])), full


def angle_figures(full, settle: float) -> dict:
    """The largest change of the GB2-to-GB1 HSS twist after the settle (time integral of
    the clean HSS speeds' difference) [rad], and the rms error of the tachometer angle
    (``pchip`` through the pulses, as the removal) against the simulation's true GB1 HSS
    angle within 0.6 s of the settle's end and elsewhere [rad]."""
    fs = float(full.attrs["sample_rate"])
    t = full.time.values
    twist = np.cumsum(full.speed_gb2_hss.values - full.speed_gb1_hss.values) / fs
    p = full.pulse_time.values
    inside = (t > p[0]) & (t < p[-1])
    true = full.angle_gb1_hss.values[inside]
    err = shaft_angle(t[inside], p) - (true - np.interp(p[0], t[inside], true))
    err -= err.mean()
    kink = np.abs(t[inside] - settle) < 0.6
    return {"twist": float(np.ptp(twist[int(round(settle * fs)):])),
            "angle_kink": float(np.sqrt(np.mean(err[kink] ** 2))),
            "angle_rest": float(np.sqrt(np.mean(err[~kink] ** 2)))}


def timed(fn, *args, **kwargs) -> tuple[np.ndarray, tuple[float, float]]:
    """Result, wall and CPU time [s] of one call (CPU: the machine may be shared)."""
    t, c = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, (time.perf_counter() - t, time.process_time() - c)


def traced(fn, *args, **kwargs) -> tuple[np.ndarray, float]:
    """Result and traced peak memory [bytes] of one call (a separate, slower run)."""
    tracemalloc.start()
    out = fn(*args, **kwargs)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out, peak


def peer_vkf(path: str | None, bandwidth: float) -> tuple:
    """rota-order's remove_orders as a removal method, or (None, reason)."""
    if path is None:
        return None, "no --peer path given"
    sys.path.insert(0, path)
    try:
        from rota.extract import remove_orders  # optional dependency (GPL peer, benchmark only)
    except ImportError as err:
        return None, f"rota-order does not import from {path}: {err}"

    def run(x, fs, pulses, families, pulses_per_rev=1):
        t = np.arange(x.size) / fs
        rpm = shaft_speed(t, pulses, pulses_per_rev=pulses_per_rev) * RPM_PER_RAD_S
        ok = np.isfinite(rpm)  # NaN outside the pulse span: hold the end speeds
        rpm = np.interp(t, t[ok], rpm[ok])
        orders = [float(o) for ords in families.values() for o in ords]
        y, _ = remove_orders(x, fs, rpm, orders, bandwidth=bandwidth)
        return y
    return run, ""


def report(name: str, ds, dt: tuple[float, float], peak: float, n: int) -> dict:
    """Print one method's rows; return its worst values."""
    modes_only = ds.band != "elsewhere"
    ch = float(np.abs(ds.change_db.sel(band=modes_only)).max())
    dist = float(ds.distortion_db.sel(band=modes_only).max())
    ch_else = float(np.abs(ds.change_db.sel(band="elsewhere")).max())
    print(f"{name:>10} {dt[0]:8.2f} {dt[1]:8.2f} {peak / 1e6:9.0f} {peak / n:7.0f}  worst "
          f"|change| {ch:5.2f} dB, worst distortion {dist:6.1f} dB; elsewhere |change| "
          f"{ch_else:5.2f} dB")
    out = {"change": ch}
    for var, what in (("leftover_db", "on the harmonic part alone"),
                      ("attenuation_db", "with the random part")):
        worst = ds[var].min("rpm")
        out[var] = worst
        print(f"{'':>10} worst-bin attenuation {what}: " + ", ".join(
            f"{f} {float(v):.1f}" for f, v in zip(ds.family.values, worst.values,
                                                  strict=True)))
    return out


#: The crossing sweeps (``--crossings``): rpm ranges that take the 3x HSS order through
#: the 62 Hz bench mode (1244 rpm) and the mesh-1 order 1.804 and shaft order 2 through
#: the 27 and 38 Hz modes (908, 1254; 819, 1131 rpm), each at the default sweep rate and
#: three times faster, each with two seeds
CROSSING_RANGES = ((500.0, 1300.0), (800.0, 1400.0))
CROSSING_RATES = (6.0, 18.0)  # rpm/s
CROSSING_SEEDS = (1, 2)


def crossing_bins(ds, families: dict, fz: np.ndarray) -> np.ndarray:
    """(band, rpm) True where an order of a family lies in the half-power band of a mode
    inside the watched band, in that bin."""
    orders = np.concatenate([np.asarray(v, dtype=float) for v in families.values()])
    marks = crossing_marks(orders, ds.rpm_lower.values, ds.rpm_upper.values, fz)
    out = np.zeros((ds.sizes["band"], ds.sizes["rpm"]), dtype=bool)
    for b, (lo, hi) in enumerate(zip(ds.band_lower.values, ds.band_upper.values,
                                     strict=True)):
        if str(ds.band.values[b]) == "elsewhere":
            continue
        inside = (fz[:, 0] >= lo) & (fz[:, 0] <= hi)
        out[b] = marks[:, :, inside].any(axis=(1, 2))
    return out


def score_sweep(cfg: dict, methods: list[str]) -> dict:
    """Every method on one sweep of ``cfg``: per method the worst mode-band change at a
    crossing and anywhere, the worst-bin leftover per family, CPU time and traced peak."""
    spec = cfg["spectra"]
    families = excitation_families(cfg)
    freq, zeta = modes(bench_ss(cfg).A)
    keep = (freq > MODE_MIN_FREQUENCY) & (freq < spec["mode_max_frequency"])
    fz = np.column_stack([freq[keep], zeta[keep]])
    x, n, pulses, fs, angles, full = records_quiet(cfg)
    params = {m: record_params(method_params(cfg["removal"], m, families, fz), full)
              for m in METHODS}
    h = x - n
    watch = structural_modes(freq, MODE_MIN_FREQUENCY, spec["mode_max_frequency"],
                             spec["mode_half_width"])
    ppr = int(cfg["tachometer"]["pulses_per_rev"])
    kw = dict(rpm_bins=spec["metric_rpm_bins"], half_width=spec["mode_half_width"],
              f_max=spec["max_frequency"], pulses_per_rev=ppr)
    out = {}
    for name in methods:
        r, dt = timed(METHODS[name], x, fs, pulses, families, ppr, **params[name])
        rh, peak = traced(METHODS[name], h, fs, pulses, families, ppr, **params[name])
        ds = separation_metrics(r, n, h, fs, pulses, families, watch, harmonic_residual=rh,
                                **kw)
        change = np.abs(ds.change_db.values)
        cross = crossing_bins(ds, families, fz)
        i = np.unravel_index(np.nanargmax(np.where(cross, change, -1.0)), change.shape)
        # the same away from the sweep's ends: crossings in the first and last rpm bins
        # are where the envelope (and the VKF's smoother) has support on one side only
        inside = cross.copy()
        inside[:, [0, -1]] = False
        out[name] = {"cross": float(change[i]) if cross.any() else np.nan,
                     "cross_inside": (float(np.max(change[inside])) if inside.any()
                                      else np.nan),
                     "where": f"{ds.band.values[i[0]]} {float(ds.rpm[i[1]]):.0f} rpm",
                     "change": float(np.nanmax(change[:-1])),
                     "change_inside": float(np.nanmax(change[:-1, 1:-1])),
                     "leftover": {str(f): float(v) for f, v in zip(
                         ds.family.values, ds.leftover_db.min("rpm").values, strict=True)},
                     "cpu": dt[1], "wall": dt[0], "peak": peak, **angles}
    return out


def records_quiet(cfg: dict) -> tuple:
    """:func:`records` without its print (the crossing sweeps print one line each)."""
    with contextlib.redirect_stdout(io.StringIO()):
        return records(cfg)


def tacho_gearbox_only(cfg: dict) -> dict:
    """``cfg`` with the excitation of gearbox 1 alone (the tachometer's): every gearbox
    line locked to the tachometer's shaft (the converters' pulsating torque as
    configured)."""
    return {**cfg, "excitation": {**cfg["excitation"], "gearboxes": ["gb1"]}}


def crossings(cfg: dict, methods: list[str], rates: tuple[float, ...] = CROSSING_RATES,
              seeds: tuple[int, ...] = CROSSING_SEEDS) -> None:
    """The crossing sweeps: every method on each, then the worst over all of them."""
    worst: dict[str, dict] = {}
    per_rate: dict[tuple[str, float], float] = {}  # (method, rate) -> worst crossing [dB]
    print(f"{'sweep':>24} {'method':>10} {'cross [dB]':>10} {'inside':>6} {'any [dB]':>8} "
          f"{'inside':>6} {'wall [s]':>8} "
          f"{'CPU [s]':>7} {'peak [MB]':>9}  worst crossing; worst-bin leftover per family "
          "[dB]")
    for (r0, r1), rate, seed in itertools.product(CROSSING_RANGES, rates, seeds):
        c = {**cfg, "seed": seed,
             "sweep": {**cfg["sweep"], "rpm_start": r0, "rpm_end": r1,
                       "duration": (r1 - r0) / rate}}
        label = f"{r0:.0f}-{r1:.0f} @{rate:g}rpm/s s{seed}"
        for name, v in score_sweep(c, methods).items():
            print(f"{label:>24} {name:>10} {v['cross']:10.2f} {v['cross_inside']:6.2f} "
                  f"{v['change']:8.2f} {v['change_inside']:6.2f} "
                  f"{v['wall']:8.1f} {v['cpu']:7.1f} {v['peak'] / 1e6:9.0f}  {v['where']}; "
                  + ", ".join(
                      f"{f} {d:.1f}" for f, d in v["leftover"].items())
                  + f"; HSS twist change {v['twist'] * 1e3:.1f} mrad; tachometer angle "
                  f"error {v['angle_kink'] * 1e6:.0f} urad rms at the ramp's start, "
                  f"{v['angle_rest'] * 1e6:.0f} elsewhere", flush=True)
            w = worst.setdefault(name, {"cross": 0.0, "inside": 0.0, "change": 0.0,
                                        "change_inside": 0.0, "wall": 0.0,
                                        "cpu": 0.0, "peak": 0.0, "leftover": {}})
            w["cross"] = max(w["cross"], v["cross"])
            w["inside"] = max(w["inside"], v["cross_inside"])
            per_rate[name, rate] = max(per_rate.get((name, rate), 0.0), v["cross"])
            w["change"] = max(w["change"], v["change"])
            w["change_inside"] = max(w["change_inside"], v["change_inside"])
            w["wall"] += v["wall"]
            w["cpu"] += v["cpu"]
            w["peak"] = max(w["peak"], v["peak"])
            for f, d in v["leftover"].items():
                w["leftover"][f] = min(w["leftover"].get(f, np.inf), d)
    print("over all crossing sweeps (worst bin of every sweep; wall and CPU summed):")
    for name, w in worst.items():
        print(f"{name:>10} worst crossing |change| {w['cross']:6.2f} dB (away from the "
              f"sweep's end bins {w['inside']:5.2f} dB), worst mode-band "
              f"|change| {w['change']:6.2f} dB ({w['change_inside']:5.2f} dB), wall "
              f"{w['wall']:6.1f} s, CPU {w['cpu']:6.1f} s, peak "
              f"{w['peak'] / 1e6:5.0f} MB; worst leftover " + ", ".join(
                  f"{f} {d:.1f}" for f, d in w["leftover"].items()))
    fams = next(iter(worst.values()))["leftover"]
    print("best method per family, worst bin over all sweeps [dB]: " + ", ".join(
        f"{f} {max(w['leftover'][f] for w in worst.values()):.1f}" for f in fams)
        + " (target >= 60)")
    # the limit of the regression's model at an isolated crossing, in the bins of these
    # sweeps, beside each method's worst crossing bin
    print_limits(cfg, [(r1 - r0) / cfg["spectra"]["metric_rpm_bins"]
                       for r0, r1 in CROSSING_RANGES], rates, per_rate)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    ap.add_argument("--methods", nargs="*", default=list(METHODS))
    ap.add_argument("--peer", default=None, help="directory holding rota-order (GPL)")
    ap.add_argument("--crossings", action="store_true",
                    help="the crossing sweeps (CROSSING_RANGES x RATES x SEEDS) instead")
    ap.add_argument("--rates", type=float, nargs="+", default=list(CROSSING_RATES),
                    help="crossing sweeps: sweep rates [rpm/s]")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(CROSSING_SEEDS),
                    help="crossing sweeps: seeds")
    ap.add_argument("--gearboxes", choices=["both", "gb1"], default="both",
                    help="crossing sweeps: gb1 = excitation of the tachometer's gearbox "
                         "alone")
    ap.add_argument("--second-angle", choices=["config", "none"], default="config",
                    help="none: the regression on the tachometer angle alone (as before "
                         "removal.regression.second_angle)")
    ap.add_argument("--peer-bandwidth", type=float, default=1.0,
                    help="rota-order VKF bandwidth [Hz] (doubled once if it refuses)")
    args = ap.parse_args()
    cfg = load(args.config)
    if args.second_angle == "none":
        cfg["removal"]["regression"]["second_angle"] = []
    if args.crossings:
        crossings(tacho_gearbox_only(cfg) if args.gearboxes == "gb1" else cfg,
                  args.methods, tuple(args.rates), tuple(args.seeds))
        return
    spec = cfg["spectra"]
    families = excitation_families(cfg)
    freq, zeta = modes(bench_ss(cfg).A)
    keep = (freq > MODE_MIN_FREQUENCY) & (freq < spec["mode_max_frequency"])
    # each method with its parameters of the config's removal section (as the workflow)
    x, n, pulses, fs, _, full = records(cfg)
    params = {m: record_params(method_params(cfg["removal"], m, families,
                                             np.column_stack([freq[keep], zeta[keep]])),
                               full) for m in METHODS}
    h = x - n
    watch = structural_modes(freq, MODE_MIN_FREQUENCY, spec["mode_max_frequency"],
                             spec["mode_half_width"])
    ppr = int(cfg["tachometer"]["pulses_per_rev"])
    print(f"sweep: {x.size} samples at {fs:g} Hz; families "
          + ", ".join(f"{k}: {[round(float(o), 4) for o in v]}" for k, v in families.items())
          + f"; modes {np.round(watch, 1).tolist()} Hz (+-{spec['mode_half_width']} Hz)")
    print(f"{'method':>10} {'wall [s]':>8} {'CPU [s]':>8} {'peak [MB]':>9} {'B/samp':>7}  "
          f"(times: on the record; peak: traced run on the harmonic part); mode bands:")
    kw = dict(rpm_bins=spec["metric_rpm_bins"], half_width=spec["mode_half_width"],
              f_max=spec["max_frequency"], pulses_per_rev=ppr)
    rows = {}
    for name in args.methods:
        r, dt = timed(METHODS[name], x, fs, pulses, families, ppr, **params[name])
        rh, peak = traced(METHODS[name], h, fs, pulses, families, ppr, **params[name])
        ds = separation_metrics(r, n, h, fs, pulses, families, watch, harmonic_residual=rh,
                                **kw)
        rows[name] = report(name, ds, dt, peak, x.size)
    for bw in (args.peer_bandwidth, 2 * args.peer_bandwidth):  # wider if refused
        run, why = peer_vkf(args.peer, bw)
        if run is None:
            print(f"rota-order VKF: not run ({why}); published reference instead: second-"
                  f"generation VKF extraction errors of -40 to -60 dB on clean, separated "
                  f"orders (Vold and Leuridan 1993; Tuma 2005)")
            break
        try:
            r, dt = timed(run, x, fs, pulses, families, ppr)
            rh, peak = traced(run, h, fs, pulses, families, ppr)
        except (MemoryError, ValueError) as err:
            print(f"rota-order VKF at {bw:g} Hz: refused here ({type(err).__name__}: {err})")
            continue
        ds = separation_metrics(r, n, h, fs, pulses, families, watch, harmonic_residual=rh,
                                **kw)
        report(f"rota {bw:g}Hz", ds, dt, peak, x.size)
        if bw != params["vkf"]["bandwidth"]:  # ours at the peer's bandwidth, side by side
            ours = {**params["vkf"], "bandwidth": bw}
            r, dt = timed(METHODS["vkf"], x, fs, pulses, families, ppr, **ours)
            rh, peak = traced(METHODS["vkf"], h, fs, pulses, families, ppr, **ours)
            ds = separation_metrics(r, n, h, fs, pulses, families, watch,
                                    harmonic_residual=rh, **kw)
            report(f"vkf {bw:g}Hz", ds, dt, peak, x.size)
        break
    if rows:
        best = {f: max(float(v["leftover_db"].sel(family=f)) for v in rows.values())
                for f in families}
        print("best method's worst-bin attenuation on the harmonic part per family [dB]: "
              + ", ".join(f"{f} {v:.1f}" for f, v in best.items()) + " (target >= 60)")
        print("smallest worst mode-band |change| [dB]: "
              f"{min(v['change'] for v in rows.values()):.2f} (target <= 1)")


if __name__ == "__main__":
    main()
