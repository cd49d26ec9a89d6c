"""How well a line can be separated from a resonance in the dwell a sweep gives: the
simulated limit of the regression's model at an isolated order/mode crossing.

At a crossing the line is the excitation times the mode's FRF along the order's
frequency; the regression models it by a slowly varying envelope (``knot_spacing`` h)
and the mode's swept response (one complex coefficient per order and mode,
:func:`gbpipe.harmonics.modal_carriers`). A least-squares fit takes, of the random
response in the mode's band, about one degree of freedom per real parameter whose
regressor lies in the band. In the rpm bin of the crossing (``Delta rpm`` wide, lasting
``T_bin = Delta rpm / rpm_rate`` s) the band holds ``2 B T_bin`` degrees of freedom of
the mode's random response (``B = pi zeta f_n``, its noise bandwidth [Hz]); the fit
spends ``2 T_bin / h`` (the envelope) plus 2 per carrier, so it takes the share

    share ~ 1 / (pi zeta f_n h) + n_carriers / (pi zeta f_n T_bin)

of the band's random power: the envelope's part does not depend on the sweep rate, the
carriers' grows with it (their two parameters are spent in an ever shorter bin). The
band reads ``10 log10(1 - share)`` dB.

Here it is simulated, free of everything else of the bench (other lines, the ramp's
start, the record's ends, the twist): the mode's (or close pair's) random response to
white noise (scipy ``lsim`` of the modes' second-order transfer functions), a record
that sweeps the order through the mode at ``rpm_rate`` with the crossing in the middle
and 8 s of sweep on both sides of the bin, the regression as configured on it (with the
mode's carriers), the band's (+-4 Hz) power in the bin against the random response's:
mean over six seeds. The sweep rate at which it reaches 1 dB is what a test engineer
needs for 1 dB at that crossing with this model; a method that reads worse on the bench
loses the rest to what the SDOF record leaves out.

Run::

    OMP_NUM_THREADS=1 python benchmarks/removal_bound.py [--rates 2 6 18 36]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import signal

from gbpipe.config import load
from gbpipe.harmonics import residual_regression
from gbpipe.lti import modes as bench_modes
from gbpipe.model import bench_ss

FS = 1000.0  # Hz: the crossings here lie below 70 Hz
MARGIN = 8.0  # s of sweep on each side of the bin (>= 3 knot intervals of 2 s)
HALF = 4.0  # Hz: the mode band read (spectra.mode_half_width)
SEEDS = (1, 2, 3, 4, 5, 6)

#: The crossings of the benchmark's sweeps (benchmarks/removal.py --crossings): order
#: [HSS orders] and the watched mode band [Hz]; the modes of the band (frequency [Hz],
#: damping ratio [-]) are the closed-loop bench's of the config (:func:`crossings`)
CROSSINGS = {
    "3x HSS / 62.2 Hz": (3.0, 62.2),
    "mesh1 1.804 / 27.3 Hz": (1.804, 27.3),
    "mesh1 1.804 / 37.7 Hz": (1.804, 37.7),
}


def crossings(cfg: dict) -> dict[str, tuple[float, tuple]]:
    """:data:`CROSSINGS` with the closed-loop bench modes of each band: name -> (order,
    ((frequency [Hz], damping ratio [-]), ...))."""
    f, z = bench_modes(bench_ss(cfg).A)
    return {name: (order, tuple((float(a), float(b)) for a, b in zip(f, z, strict=True)
                                if abs(a - band) <= HALF))
            for name, (order, band) in CROSSINGS.items()}


def band_powers(order: float, modes: tuple, rpm_rate: float, bin_rpm: float,
                knot_spacing: float, seed: int) -> tuple[float, float]:
    """Band power of the random response after the regression and before it, in the bin
    of the crossing [unit^2] (the noise alone: the fit is linear, and its model of the
    line is exact here, so the line adds nothing to the change)."""
    fn = np.mean([f for f, _ in modes])
    f_cross = fn / order  # shaft rate at the crossing [rev/s]
    rate = rpm_rate / 60.0  # [rev/s^2]
    t_bin = bin_rpm / rpm_rate
    t = np.arange(-(t_bin / 2 + MARGIN) * FS, (t_bin / 2 + MARGIN) * FS) / FS
    f0 = f_cross + rate * t[0]
    tt = t - t[0]
    theta = 2 * np.pi * (f0 * tt + 0.5 * rate * tt**2)
    k = np.arange(1, int(theta[-1] / (2 * np.pi)) + 1)
    pulses = (-f0 + np.sqrt(f0**2 + 2 * rate * k)) / rate  # theta(t) = 2 pi k
    white = np.random.default_rng(seed).standard_normal(tt.size + int(5 * FS))
    noise = np.zeros(white.size)
    for f, z in modes:  # the modes' response to one white force (one path), settled
        wn = 2 * np.pi * f
        _, y, _ = signal.lsim(signal.lti([wn**2], [1.0, 2 * z * wn, wn**2]), white,
                              np.arange(white.size) / FS)
        noise += y
    noise = noise[int(5 * FS):]
    r = residual_regression(noise, FS, pulses, {"line": [order]},
                            knot_spacing=knot_spacing, modes=list(modes), mode_reach=3.0)
    sel = np.abs(t) <= t_bin / 2
    out = []
    for x in (r, noise):
        f, p = signal.periodogram(x[sel], FS, window="hann")
        out.append(float(p[np.abs(f - fn) <= HALF].sum()))
    return out[0], out[1]


def bound(crossing: tuple, rpm_rate: float, bin_rpm: float = 50.0,
          knot_spacing: float = 2.0) -> tuple[float, float]:
    """Band change [dB] at a crossing (order, modes): of the power summed over
    :data:`SEEDS` (the mean share), and the largest of a single seed (one record's bin:
    the share of a few parameters scatters from record to record)."""
    pw = np.array([band_powers(*crossing, rpm_rate, bin_rpm, knot_spacing, s)
                   for s in SEEDS])
    one = 10 * np.log10(pw[:, 0] / pw[:, 1])
    return (float(10 * np.log10(pw[:, 0].sum() / pw[:, 1].sum())),
            float(one[np.argmax(np.abs(one))]))


def predicted(crossing: tuple, rpm_rate: float, bin_rpm: float = 50.0,
              knot_spacing: float = 2.0) -> float:
    """The count of the module notes [dB]."""
    _, modes = crossing
    b = np.pi * np.mean([f * z for f, z in modes])
    share = 1 / (b * knot_spacing) + len(modes) / (b * bin_rpm / rpm_rate)
    return float(10 * np.log10(max(1 - share, 1e-3)))


def rate_for(target_db: float, rates: np.ndarray, bins: np.ndarray) -> str:
    """The fastest sweep rate of ``rates`` up to which every bound is within
    ``target_db``."""
    ok = None
    for r, b in sorted(zip(rates, bins, strict=True)):
        if abs(b) > target_db:
            break
        ok = r
    return f"{ok:g} rpm/s" if ok is not None else f"none (from {min(rates):g} rpm/s)"


def print_limits(cfg: dict, bins: list[float], rates: tuple[float, ...],
                 worst: dict[tuple[str, float], float]) -> None:
    """Print, per sweep rate, the limit at each crossing of ``cfg``'s bench in rpm bins of
    ``bins`` widths (mean / worst seed), beside ``worst[(method, rate)]``, each method's
    worst crossing bin [dB] on the bench records (``benchmarks/removal.py --crossings``)."""
    bins = sorted(set(bins))
    h = cfg["removal"]["regression"]["knot_spacing"]
    h = float(h["default"] if isinstance(h, dict) else h)
    limits = crossings(cfg)
    methods = sorted({m for m, _ in worst})
    for rate in rates:
        lim = {name: [bound(c, rate, b, h) for b in bins] for name, c in limits.items()}
        print(f"at {rate:g} rpm/s, isolated-crossing limit (band change in "
              f"{', '.join(f'{b:.0f}' for b in bins)} rpm bins, mean / worst seed, h = "
              f"{h:g} s): " + "; ".join(f"{n} " + ", ".join(f"{m:+.2f}/{w:+.2f}"
                                                          for m, w in ls)
                                        for n, ls in lim.items())
              + " dB; worst crossing bin per method: " + ", ".join(
                  f"{m} {worst[m, rate]:.2f}" for m in methods) + " dB", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(Path(__file__).resolve().parents[1] / "config"
                                             / "config.yaml"))
    ap.add_argument("--rates", type=float, nargs="*", default=[2, 4, 6, 9, 12, 18, 27, 36])
    ap.add_argument("--bin-rpm", type=float, default=50.0)
    ap.add_argument("--knot-spacing", type=float, default=2.0)
    args = ap.parse_args()
    rates = np.array(args.rates)
    print(f"band change [dB] in the {args.bin_rpm:g} rpm bin of the crossing: of the "
          f"power over seeds {SEEDS} / the worst seed (the count of the notes in "
          f"brackets); h = {args.knot_spacing:g} s")
    print(f"{'crossing':>24} " + " ".join(f"{r:>20g}" for r in rates) + "  rpm/s")
    for name, c in crossings(load(args.config)).items():
        b = np.array([bound(c, r, args.bin_rpm, args.knot_spacing) for r in rates])
        p = [predicted(c, r, args.bin_rpm, args.knot_spacing) for r in rates]
        print(f"{name:>24} " + " ".join(f"{v:6.2f}/{w:6.2f} ({q:5.2f})" for (v, w), q in zip(
            b, p, strict=True)) + f"  | mean within 1 dB up to {rate_for(1.0, rates, b[:, 0])}"
              f", every seed up to {rate_for(1.0, rates, b[:, 1])}", flush=True)


if __name__ == "__main__":
    main()
