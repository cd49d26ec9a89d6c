"""openTorsion assemblies through gbpipe's import and builder, against openTorsion itself.

Many random chains nobody tuned anything to: per seed a tree of 8-60 nodes (a shaft line
that gear meshes split into branches: a parent gear may drive two children), 1-6 meshes
with radius ratios 1:0.2-1:5, each mesh rigid (``Gear``) or, one in two, elastic
(``ElasticGear``, 1e5-1e8 N·m/rad, damped), shafts geometric (steel, consistent mass) or
stiffness-given (with or without own inertia), inertias 0.01-10 kg·m², damped ground
springs on 1-3 random nodes (the builder refuses a part neither grounded nor driven) and
dampers to ground (``Disk`` with ``c``, no ``k``) on 0-3 others.
Each is imported (``from_assembly``), built through the chain builder, and compared with
openTorsion:

* undamped frequencies against ``modal_analysis(C=0)`` [relative];
* damped poles against ``modal_analysis()`` [relative];
* the driving-point FRF (torque and speed at the first node) against
  ``(−ω²M + jωC + K)⁻¹`` of openTorsion's own ``M``, ``C``, ``K`` and ``T`` [relative];
* the round trip ``from_assembly(to_assembly(d)) == d`` (largest relative change);

and the CPU time of import + build [ms]. Printed: the worst of each over the seeds.

Usage: ``OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/opentorsion_io.py [n_seeds]``.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import opentorsion as ot

from gbpipe.lti import frf
from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_io import from_assembly, to_assembly
from gbpipe.model.statespace import mechanism_ss


def random_chain(seed: int) -> ot.Assembly:
    """A random tree of shafts and meshes (module docstring)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(8, 61))
    n_gears = int(rng.integers(1, min(6, n // 3) + 1))
    links = list(range(1, n))          # node i hangs on an earlier node by a shaft or mesh
    meshed = set(rng.choice(links, size=n_gears, replace=False).tolist())
    parent_node = {i: int(rng.integers(max(0, i - 3), i)) if i in meshed else i - 1
                   for i in links}
    shafts, gears, elastic = [], {}, {}
    for i in links:
        p = parent_node[i]
        if i in meshed:
            if p not in gears:
                gears[p] = ot.Gear(p, float(rng.uniform(0.01, 1.0)), 1.0,
                                   parent=None)
            inertia, radius = float(rng.uniform(0.01, 1.0)), float(rng.uniform(0.2, 5.0))
            if rng.integers(2):
                elastic[i] = ot.ElasticGear(i, inertia, radius, k=float(10 ** rng.uniform(5, 8)),
                                            c=float(rng.uniform(0, 20)), parent=gears[p])
            else:
                gears[i] = ot.Gear(i, inertia, radius, parent=gears[p])
            continue
        kind = rng.integers(3)
        c = float(rng.uniform(0.0, 50.0))
        if kind == 0:
            shafts.append(ot.Shaft(p, i, L=float(rng.uniform(100, 800)),
                                   odl=float(rng.uniform(30, 150)), c=c))
        else:
            shafts.append(ot.Shaft(p, i, k=float(10 ** rng.uniform(4, 7)),
                                   I=float(rng.uniform(0, 0.01)) if kind == 1 else 0.0, c=c))
    picked = rng.choice(n, size=int(rng.integers(1, 4)) + 3, replace=False).tolist()
    grounded, damped = set(picked[:-3]), set(picked[-int(rng.integers(0, 4)):] if
                                             rng.integers(4) else [])
    damped -= grounded
    disks = [ot.Disk(i, float(10 ** rng.uniform(-2, 1)),
                     c=float(rng.uniform(1, 100)) if i in grounded | damped else 0.0,
                     k=float(10 ** rng.uniform(2, 5)) if i in grounded else 0.0)
             for i in range(n) if i not in gears]
    # a grounded gear node: its spring on an inertia-free disk (the gear has the inertia)
    disks += [ot.Disk(i, 0.0, c=float(rng.uniform(1, 100)), k=float(10 ** rng.uniform(2, 5)))
              for i in sorted(grounded & set(gears))]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=list(gears.values()),
                       elastic_gear_elements=list(elastic.values()) or None)


def compare(seed: int) -> dict[str, float]:
    asm = random_chain(seed)
    t0 = time.process_time()
    desc = from_assembly(asm)
    mech = build_chain(desc).mechanism
    cpu = time.process_time() - t0
    w0, wd0, _ = (np.asarray(a) for a in asm.modal_analysis(C=np.zeros_like(asm.M)))
    w0 = np.sort(w0[wd0 > 0]) / (2 * np.pi)     # one per ±jω pair (every chain grounded)
    f_ud = mech.undamped_frequencies()
    # a mode 1e-6 of the highest in frequency is 1e-12 of it in ω², where either solver's
    # round-off (eps·ω_max²) is 1e-4 of it: compared above 1e-5 of the highest only
    w0, f_ud = (f[f > 1e-5 * f.max()] for f in (w0, f_ud))
    wn, wd, zeta = (np.asarray(a) for a in asm.modal_analysis())
    up = (wd > 1e-6 * wn.max())
    ref = np.sort_complex((-zeta * wn + 1j * wd)[up])
    sys_ = mechanism_ss(mech, {"t": ("n0", 1.0)}, {}, {"w": "n0"}, {})
    poles = np.linalg.eigvals(sys_.A)
    poles = np.sort_complex(poles[poles.imag > 1e-6 * wn.max()])
    f = np.geomspace(0.5, 2.0 * f_ud.max(), 200)
    t = asm.T(asm.E())
    h_ref = np.array([1j * w * (t @ np.linalg.solve(-w**2 * asm.M + 1j * w * asm.C + asm.K,
                                                   t[0]))[0] for w in 2 * np.pi * f])
    back = from_assembly(to_assembly(desc))
    trip = max(abs(a[k] / b[k] - 1) for kind in ("shafts", "mounts", "gears")
               for a, b in zip(back[kind], desc[kind], strict=True)
               for k in b if isinstance(b[k], float) and b[k])
    trip = max(trip, *(abs(back["disks"][n]["inertia"] / d["inertia"] - 1)
                       for n, d in desc["disks"].items() if d["inertia"]))
    return {"nodes": len(desc["disks"]), "meshes": len(desc["gears"]),
            "elastic": sum("stiffness" in g for g in desc["gears"]),
            "dampers": sum(not m["stiffness"] for m in desc["mounts"]),
            "undamped": float(np.abs(f_ud / w0 - 1).max()) if len(w0) == len(f_ud)
            else np.inf,
            "poles": float(np.abs(poles / ref - 1).max()) if len(poles) == len(ref)
            else np.inf,
            "frf": float(np.abs(frf(sys_, f)[:, 0, 0] / h_ref - 1).max()),
            "round_trip": float(trip), "cpu_ms": 1e3 * cpu}


def main(n_seeds: int = 200) -> None:
    rows = [compare(seed) for seed in range(n_seeds)]
    print(f"{n_seeds} random chains: {min(r['nodes'] for r in rows)}-"
          f"{max(r['nodes'] for r in rows)} nodes, {min(r['meshes'] for r in rows)}-"
          f"{max(r['meshes'] for r in rows)} meshes ({sum(r['elastic'] for r in rows)} "
          f"elastic), {sum(r['dampers'] for r in rows)} dampers to ground")
    for key, unit in (("undamped", "relative"), ("poles", "relative"),
                      ("frf", "relative"), ("round_trip", "relative"),
                      ("cpu_ms", "ms of CPU, import + build")):
        values = np.array([r[key] for r in rows])
        print(f"  {key:>10}: worst {values.max():.2e}, median {np.median(values):.2e} "
              f"({unit})")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
