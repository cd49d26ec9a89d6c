"""Benchmark: one identify job (test x profile x method, every pairing x data version).

1. The whole job (:func:`gbpipe.identify.identify_record`): CPU time on one core, split into
   the sysid core (the :mod:`gbpipe.sysid` method calls) and the identify layer (the rest:
   conditioning, validation fit, FRFs, metrics, dataset), and the growth of the process's
   peak resident set.
2. The identify layer's two largest pieces beside what they replace, same data, same
   process: conditioning each (record, version, signal) once
   (:class:`gbpipe.identify.ConditionedRecord`) against conditioning every pairing x
   version (:func:`gbpipe.identify.condition` per pairing); the one-pass segment fit
   (:meth:`gbpipe.sysid.SubspaceModel.simulate_segments`) against ``estimate_x0`` +
   ``simulate`` per segment, with the largest difference of the fits [%].

Inputs: a complete run's ``results/`` (records, ``tsa/tests``, ``removal/tests``,
``model/truth.nc``) and the config that made it.

Usage: ``OMP_NUM_THREADS=1 python benchmarks/identify.py [--results results]
[--config config/config.yaml] [--test speed_up] [--profile square] [--method moesp]``.
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np

from gbpipe import io, sysid
from gbpipe.config import load
from gbpipe.identify import (
    VALIDATION_PARTNER,
    VERSIONS,
    ConditionedRecord,
    condition,
    fit_model,
    identify_record,
    version_signals,
)
from gbpipe.lti import fit_percent

ROOT = Path(__file__).resolve().parents[1]


def _cpu(fun, *args):
    t = time.process_time()
    out = fun(*args)
    return time.process_time() - t, out


def _timed(fun, total: list[float]):
    # fun, adding its CPU time to total[0]
    def wrapper(*args, **kw):
        t = time.process_time()
        try:
            return fun(*args, **kw)
        finally:
            total[0] += time.process_time() - t
    return wrapper


def _per_segment(model, u, y, segment):
    # the validation fit before: estimate_x0 and simulate per segment
    y_sim = np.empty_like(y)
    for a in range(0, len(u), segment):
        b = min(len(u), a + segment)
        y_sim[a:b] = (y[a:b] if b - a < model.order else
                      model.simulate(u[a:b], model.estimate_x0(u[a:b], y[a:b])))
    return y_sim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=ROOT / "results")
    ap.add_argument("--config", type=Path, default=ROOT / "config" / "config.yaml")
    ap.add_argument("--test", default="speed_up")
    ap.add_argument("--profile", default="square")
    ap.add_argument("--method", default="moesp")
    a = ap.parse_args()
    cfg = load(a.config)
    s, r = cfg["identify"], a.results
    val = VALIDATION_PARTNER[a.test]
    name = f"{a.test}_{a.profile}"
    removed = {v: (io.read(r / d / f"{name}.nc"), io.read(r / d / f"{val}_{a.profile}.nc"))
               for v in s["versions"] if v not in ("clean", "raw")
               for d in [Path("tsa/tests") if v == "tsa" else Path("removal/tests") / v]}
    rec, vrec = io.read(r / "simulate" / f"{name}.nc"), io.read(r / "simulate" /
                                                                 f"{val}_{a.profile}.nc")
    truth = io.read(r / "model" / "truth.nc")
    job = {"campaign": {"settle": cfg["campaign"]["settle"]}, "identify": s}

    core = [0.0]
    for meth in ("pbsid", "moesp", "n4sid"):
        setattr(sysid, meth, _timed(getattr(sysid, meth), core))
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    cpu, ds = _cpu(lambda: identify_record(job, rec, vrec, truth, a.method, removed))
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0
    print(f"job {name} {a.method}: {ds.sizes['model']} models, CPU {cpu:.2f} s = sysid core "
          f"{core[0]:.2f} s + identify layer {cpu - core[0]:.2f} s; peak RSS +{rss / 1e3:.0f} MB")

    fs, grid = float(rec.attrs["sample_rate"]), (cfg["campaign"]["settle"], s["sample_rate"],
                                                 s["lowpass"])

    def per_pairing():
        for p in s["pairings"]:
            for v in s["versions"]:
                for k in ("inputs", "outputs"):
                    condition(version_signals(rec, p[k], v, removed.get(v, (None,))[0]), fs,
                              *grid)

    def once():
        c = ConditionedRecord(rec, {v: x for v, (x, _) in removed.items()}, fs, *grid)
        for p in s["pairings"]:
            for v in s["versions"]:
                c(p["inputs"], v), c(p["outputs"], v)
        return c

    t_old, _ = _cpu(per_pairing)
    t_new, c_rec = _cpu(once)
    print(f"conditioning of one record: per pairing x version {t_old:.2f} s, each signal "
          f"once {t_new:.2f} s")
    c_val = ConditionedRecord(vrec, {v: x for v, (_, x) in removed.items()}, fs, *grid)
    seg = int(round(s["fit_segment"] * s["sample_rate"]))
    t_old = t_new = diff = 0.0
    wild = 0  # models whose free response grows > 1e8 in a segment: both fits are rounding
    for p in s["pairings"]:
        v = VERSIONS[1]  # raw: every pairing is persistently excited
        u, y = c_rec(p["inputs"], v), c_rec(p["outputs"], v)
        m = fit_model(a.method, u, y, 1.0 / s["sample_rate"], s)
        uv, yv = c_val(p["inputs"], v), c_val(p["outputs"], v)
        dt_old, y_old = _cpu(_per_segment, m, uv, yv, seg)
        dt_new, (y_new, _) = _cpu(m.simulate_segments, uv, yv, seg)
        t_old, t_new = t_old + dt_old, t_new + dt_new
        if np.max(np.abs(np.linalg.eigvals(m.A))) ** seg > 1e8:
            wild += 1
            continue
        diff = max(diff, float(np.max(np.abs(fit_percent(yv, y_old) - fit_percent(yv, y_new)))))
    print(f"validation fit of the {len(s['pairings'])} raw models: per segment {t_old:.3f} s, "
          f"one pass {t_new:.3f} s; largest fit difference {diff:.2e} % ({wild} models "
          "growing > 1e8 in a segment not compared)")


if __name__ == "__main__":
    main()
