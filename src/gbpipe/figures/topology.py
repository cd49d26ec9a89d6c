"""Figure 5: the model's topology, drawn from the mechanism built from config.

Nothing is hard-coded to one gearbox: bodies, stages, shafts, mounts, motors and torque
meters are read from :func:`gbpipe.model.bench_mechanism`, so another gearbox gives its
own drawing.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.patches import Circle, FancyBboxPatch

from gbpipe.figures.style import new, save
from gbpipe.kinematics import parse_stages
from gbpipe.model import bench_mechanism

__all__ = ["fig5_topology"]


def _chain(mech) -> list[str]:
    """Independent coordinates along the power path, from the driver motor."""
    body_coord = {}
    for b, row in zip(mech.bodies, mech.T, strict=True):
        nz = [mech.coords[i] for i in np.nonzero(row)[0] if not mech.coords[i].endswith("housing")]
        if nz:
            body_coord[b.name] = nz[0]
    adj: dict[str, list[tuple[str, Any]]] = {}
    for s in mech.springs:
        if s.kind == "mount":
            continue
        a, b = (body_coord[n] for n in s.incidence)
        adj.setdefault(a, []).append((b, s))
        adj.setdefault(b, []).append((a, s))
    order, seen, node = [], set(), mech.coords[0]
    while node is not None:
        order.append(node)
        seen.add(node)
        node = next((n for n, _ in adj.get(node, []) if n not in seen), None)
    return order, adj


def _zigzag(ax, x0, x1, y, color="k", n=6, h=0.08):
    xs = np.linspace(x0, x1, 2 * n + 1)
    ys = y + h * np.array([0] + [(-1) ** i for i in range(2 * n - 1)] + [0])
    ax.plot(xs, ys, color=color, lw=1)


def fig5_topology(cfg: Mapping[str, Any], stem) -> None:
    """Draw the bench and gearbox topology (paper Fig. 5, extended to the bench)."""
    mech, _ = bench_mechanism(cfg)
    stages = parse_stages(cfg["gearbox"]["stages"])
    order, adj = _chain(mech)
    inertia = {c: mech.reflected_inertia(c) for c in mech.coords}
    fig, ax = new(figsize=(max(9.0, 1.25 * len(order)), 4.2))
    ax.set_axis_off()
    ax.grid(False)
    x = {c: i * 1.25 for i, c in enumerate(order)}
    for c in order:
        kind = ("motor" if c.endswith("motor") else "flange" if c.endswith("flange")
                else "stage")
        if kind == "motor":
            ax.add_patch(Circle((x[c], 0), 0.32, fc="#d9e7f5", ec="k"))
            ax.text(x[c], 0, "M", ha="center", va="center", fontsize=12, weight="bold")
            label = f"{c.replace('_', ' ')}\nJ={inertia[c]:.0f} kg·m²"
        else:
            h = 0.35 + 0.12 * np.log10(max(inertia[c], 1.0))
            ax.add_patch(FancyBboxPatch((x[c] - 0.3, -h / 2), 0.6, h, fc="#f2e3c6", ec="k",
                                        boxstyle="round,pad=0.02"))
            gb, _, part = c.partition(".")
            if kind == "stage":
                k = int(part[5:])
                st = stages[k - 1]
                teeth = "/".join(str(v) for v in st.teeth.values())
                extra = f"×{st.planets}" if st.type == "planetary" else ""
                ax.text(x[c], 0, f"S{k}", ha="center", va="center", weight="bold")
                label = f"{gb} {st.type}\n{teeth}{extra}\nJ={inertia[c]:.3g}"
            else:
                ax.text(x[c], 0, "HSS", ha="center", va="center", fontsize=7, weight="bold")
                label = f"{gb} flange\nJ={inertia[c]:.3g}"
        ax.text(x[c], -0.62, label, ha="center", va="top", fontsize=6.5)
    drawn = set()
    for a in order:
        for b, s in adj.get(a, []):
            if s.name in drawn or b not in x:
                continue
            drawn.add(s.name)
            x0, x1 = sorted((x[a], x[b]))
            color = "C3" if s.kind == "coupling" else "C0" if s.kind == "lss_shaft" else "k"
            _zigzag(ax, x0 + 0.32, x1 - 0.32, 0.0, color=color)
            tag = "TM + coupling" if s.kind == "coupling" else s.name.split(".")[-1]
            ax.text((x0 + x1) / 2, 0.16, f"{tag}\nk={s.stiffness:.3g}", ha="center",
                    va="bottom", fontsize=6.5, color=color)
    # housings on mounts, above their gearboxes; ring gears tie the planetary stages to them
    for gb in ("gb1", "gb2"):
        members = [c for c in order if c.startswith(f"{gb}.")]
        if f"{gb}.housing" not in mech.coords or not members:
            continue
        xs = [x[c] for c in members]
        y = 1.25
        ax.add_patch(FancyBboxPatch((min(xs) - 0.3, y - 0.18), max(xs) - min(xs) + 0.6, 0.36,
                                    fc="#e5e5e5", ec="k", boxstyle="round,pad=0.02"))
        m = mech.spring(f"{gb}.mount")
        ax.text(np.mean(xs), y, f"{gb} housing J={inertia[f'{gb}.housing']:.3g} kg·m²",
                ha="center", va="center", fontsize=7)
        for c in members:
            if c.endswith("flange"):
                continue
            ax.plot([x[c], x[c]], [0.3, y - 0.18], ls="--", color="0.4", lw=0.8)
        xm = max(xs) + 0.55
        ax.plot([max(xs) + 0.3, xm], [y, y], color="k", lw=1)
        ax.plot([xm, xm + 0.001], [y, y], color="k")
        ys = np.linspace(y, y + 0.55, 13)
        ax.plot(xm + 0.06 * np.array([0] + [(-1) ** i for i in range(11)] + [0]), ys,
                color="C2", lw=1)
        ax.plot([xm - 0.15, xm + 0.15], [y + 0.55, y + 0.55], color="k", lw=2)
        ax.text(xm + 0.12, y + 0.3, f"mount\nk={m.stiffness:.3g}", fontsize=6.5, color="C2")
    ax.set_xlim(-0.8, x[order[-1]] + 0.8)
    ax.set_ylim(-1.6, 2.1)
    ax.set_aspect("equal")
    ax.set_title("Fig. 5 — model topology from config: motors, torque meters (TM), couplings, "
                 "gearbox stages (rigid gears), shafts and housings on elastic mounts "
                 "(k in N·m/rad on own shaft; J in kg·m² at own speed)", fontsize=8)
    save(fig, stem)
