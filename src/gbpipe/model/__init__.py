"""Torsional models of a multi-stage gearbox and of the back-to-back test bench.

numpy-level API (what gbpipe uses; python-control is not imported)
-------------------------------------------------------------------
gearbox_ss(cfg), bench_ss(cfg, closed=True)
    :class:`gbpipe.lti.NamedSS` of one gearbox (free at both ends) and of the complete
    bench (closed loop: references, motor-torque disturbances and excitation angles in;
    speeds, angles, torque meters and motor torques out; ``closed=False``: the open-loop
    plant with the two motor torques as inputs).
check_stability(cfg)
    Raises :class:`gbpipe.errors.UnstableGain` naming the PI gain that destabilises the
    closed-loop bench.
truth_model, true_modes, truth_dataset
    The true model of an identification pairing, its modes, and all pairings' FRFs and
    modes as an ``xarray.Dataset`` (``results/model/truth.nc``).
build_chain, Chain, paper_drivetrain, bench_chain
    Any torsional chain from its ``drivetrain:`` description (docs/drivetrain.md); the
    paper's bench as one such description; the config's bench built.
gearbox_mechanism, bench_mechanism, Mechanism, Body, Spring
    The mechanisms behind the state spaces.
model_datasets(cfg, truth_cfg)
    The gearbox, bench and truth datasets of the model stage (``results/model/*.nc``).
Pairing, pairing_frf
    Batched FRFs of the identification pairings (a fitting loop's model evaluation).

``control.StateSpace`` forms: ``from gbpipe.model.control_models import gearbox, bench``.
FRFs and modes of any state space: :func:`gbpipe.lti.frf`, :func:`gbpipe.lti.modes`.
See docs/architecture.md, "Physics".
"""

from __future__ import annotations

from gbpipe.model.assembly import bench_chain, bench_ss, gearbox_ss
from gbpipe.model.chain import Chain, build_chain
from gbpipe.model.drivetrain import bench_mechanism, gearbox_mechanism, paper_drivetrain
from gbpipe.model.frf import Pairing, pairing_frf
from gbpipe.model.mechanics import Body, Mechanism, Spring
from gbpipe.model.stability import check_stability
from gbpipe.model.stage import model_datasets
from gbpipe.model.truth import (
    TORQUES,
    true_modes,
    truth_dataset,
    truth_model,
)

__all__ = [
    "gearbox_ss", "bench_ss", "check_stability", "truth_model", "true_modes",
    "truth_dataset", "TORQUES", "Mechanism", "Body", "Spring", "gearbox_mechanism",
    "bench_mechanism", "build_chain", "Chain", "paper_drivetrain", "bench_chain",
    "model_datasets", "Pairing", "pairing_frf",
]
