"""Lumped torsional mechanics with kinematic constraints.

A :class:`Mechanism` holds the *physical* angle of every body (carriers, planets, suns,
wheels, pinions, flanges, housings, motors), the springs between them, and a constraint
matrix ``T`` that expresses every physical angle through the independent coordinates
``q`` (``θ_full = T q``). Rigid gear meshes are constraints; shafts, couplings, mounts,
dampers to ground (a spring of stiffness 0) and elastic gear meshes (a spring whose twist
is the mesh's relative angle, ``θ_parent − θ_child/r``) are springs. The reduced
equations of motion are

    M q̈ + C q̇ + K q = Bᵀ u,   M = Tᵀ M_full T,  K = Σ k Tᵀ g gᵀ T,  C = Σ c Tᵀ g gᵀ T,

with ``g`` a spring's incidence vector over the physical angles (its twist is ``g·θ_full``).
Reflecting inertias to one shaft cannot express a rotating ring (a housing on elastic
torque-arm mounts): the constraint form can, since the ring angle is simply the housing
angle in the gear constraint.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import eigh, null_space

__all__ = ["Body", "Spring", "Mechanism"]


@dataclass
class Body:
    """A rotating body with a physical angle.

    Its angle is an independent coordinate of the :class:`Mechanism`, unless a gear mesh
    constraint expresses it through the others.

    Attributes
    ----------
    name : str
        Unique name, e.g. ``gb1.carrier1``.
    inertia : float
        Own-axis inertia [kg·m²] (may be 0 for a massless member).
    kind : str
        ``gear``, ``flange``, ``housing``, ``motor`` … (for drawings and reports).
    group : str
        Gearbox or bench part the body belongs to (``gb1``, ``gb2``, ``bench``).
    """

    name: str
    inertia: float
    kind: str = "body"
    group: str = ""


@dataclass
class Spring:
    """A torsional spring-damper whose twist is ``Σ g_i θ_i`` over physical angles.

    Attributes
    ----------
    name : str
        Unique name, e.g. ``gb1.shaft2``.
    incidence : dict
        Body name → coefficient; ``{"b": 1, "a": -1}`` is the twist ``θ_b − θ_a``.
        A body missing from the mechanism's coordinates is ground (angle 0).
    stiffness : float
        [N·m/rad]; 0 for a pure damper (a dashpot to ground: bearing losses).
    damping : float
        [N·m·s/rad].
    kind : str
        ``shaft``, ``coupling``, ``mount``, ``mesh`` (an elastic gear mesh) … .
    damping_ratio : float
        The ratio the damping was derived from (kept for reports).
    inertia : float
        The element's own inertia [kg·m²], spread uniformly along it (consistent mass:
        a shaft twisting linearly adds ``½J(θ̄̇² + Δθ̇²/12)`` to the kinetic energy, θ̄
        the mean angle of its ends, Δθ its twist); 0 for a massless spring.
    """

    name: str
    incidence: dict[str, float]
    stiffness: float
    damping: float = 0.0
    kind: str = "shaft"
    damping_ratio: float = 0.0
    inertia: float = 0.0


@dataclass
class Mechanism:
    """Bodies, springs and the constraint map from independent coordinates to angles.

    Attributes
    ----------
    bodies : list of Body
    springs : list of Spring
    coords : list of str
        Names of the independent coordinates ``q``.
    T : ndarray, shape (n_bodies, n_coords)
        ``θ_full = T q``.
    meshes : list of dict
        Rigid gear meshes (for drawings): ``{"name", "members", "stage", "group"}``.
    """

    bodies: list[Body] = field(default_factory=list)
    springs: list[Spring] = field(default_factory=list)
    coords: list[str] = field(default_factory=list)
    T: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    meshes: list[dict] = field(default_factory=list)

    # -- assembly ------------------------------------------------------------------
    @property
    def body_index(self) -> dict[str, int]:
        return {b.name: i for i, b in enumerate(self.bodies)}

    def incidence_vector(self, spring: Spring) -> np.ndarray:
        """Incidence of a spring over the physical angles (ground entries dropped)."""
        return _incidence([spring], self.body_index, len(self.bodies))[0]

    def twist_map(self, spring: Spring) -> np.ndarray:
        """Row vector mapping ``q`` to the spring's twist [rad]."""
        return self.incidence_vector(spring) @ self.T

    def twist_maps(self) -> dict[str, np.ndarray]:
        """Every spring's :meth:`twist_map`, by spring name (in the order of ``springs``).

        One body index serves all springs: a fit assembles the mechanism per model
        evaluation, and rebuilding the index per spring was a large share of that.
        """
        rows = _incidence(self.springs, self.body_index, len(self.bodies)) @ self.T
        return {s.name: h for s, h in zip(self.springs, rows, strict=True)}

    @property
    def mass_matrix(self) -> np.ndarray:
        """Reduced inertia matrix ``M = Tᵀ M_full T`` [kg·m²], plus the springs' own."""
        j = np.array([b.inertia for b in self.bodies])
        m = self.T.T @ (j[:, None] * self.T)
        for s in self.springs:
            if s.inertia:
                # consistent mass J/6·[[2, 1], [1, 2]] of the ends = J(θ̄θ̄ᵀ + ΔθΔθᵀ/12)
                e = self.incidence_vector(s)
                g, mean = e @ self.T, 0.5 * np.abs(e) @ self.T
                m += s.inertia * (np.outer(mean, mean) + np.outer(g, g) / 12.0)
        return m

    @property
    def stiffness_matrix(self) -> np.ndarray:
        """Reduced stiffness matrix [N·m/rad]."""
        return self.spring_matrices()[0]

    def spring_matrices(self, twist: Mapping[str, np.ndarray] | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
        """Reduced stiffness [N·m/rad] and damping [N·m·s/rad] matrices in one pass.

        Parameters
        ----------
        twist : mapping, optional
            :meth:`twist_maps`, when the caller has them already.
        """
        twist = self.twist_maps() if twist is None else twist
        n = len(self.coords)
        h = np.array([twist[s.name] for s in self.springs]).reshape(len(self.springs), n)
        hh = h[:, :, None] * h[:, None, :]          # each spring's outer product
        # np.sum along a slow axis adds term by term, in spring order (pairwise summation
        # is for the fast axis): the numbers of a loop over the springs, in fewer steps
        k = np.sum(np.array([s.stiffness for s in self.springs])[:, None, None] * hh, axis=0)
        c = np.sum(np.array([s.damping for s in self.springs])[:, None, None] * hh, axis=0)
        return k, c

    def torque_input(self, body: str, sign: float = 1.0) -> np.ndarray:
        """Generalised force of a torque [N·m] applied on a physical body: ``Tᵀ e_body``."""
        return sign * self.T[self.body_index[body]]

    def angle_error_inputs(self, springs: Sequence[str],
                           twist: Mapping[str, np.ndarray] | None = None) -> list[np.ndarray]:
        """Generalised forces of a prescribed angle error [rad] inside each spring.

        With rigid gears a transmission error is an angle added to the twist of the
        shaft next to the mesh, so it acts as the torque ``−k·e`` through that spring.

        Parameters
        ----------
        springs : sequence of str
            Spring names.
        twist : mapping, optional
            :meth:`twist_maps`, when the caller has them already.
        """
        out = []
        for name in springs:
            s = self.spring(name)
            out.append(-s.stiffness * (self.twist_map(s) if twist is None else twist[name]))
        return out

    def spring(self, name: str) -> Spring:
        for s in self.springs:
            if s.name == name:
                return s
        raise KeyError(f"no spring named {name!r}; have {[s.name for s in self.springs]}")

    def reflected_inertia(self, coord: str) -> float:
        """Inertia felt at a coordinate with every other coordinate held [kg·m²]."""
        i = self.coords.index(coord)
        return float(self.mass_matrix[i, i])

    # -- eigen-analysis --------------------------------------------------------------
    def rigid_modes(self) -> np.ndarray:
        """Rigid-body modes: orthonormal columns over ``coords`` that twist no spring [rad].

        The null space of the twist maps of the springs with a stiffness (entries are gear
        ratios, not stiffnesses): counted there, a soft mount's mode decades below the
        stiffest one is never taken for rigid. A pure damper (stiffness 0, e.g. bearing
        losses to ground) stores no energy: a motion that only works it is still a
        rigid-body mode (ω = 0), damped.
        """
        maps = self.twist_maps()
        twist = np.array([maps[s.name] for s in self.springs if s.stiffness > 0])
        return null_space(twist.reshape(-1, len(self.coords)))

    def undamped_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies [Hz] from ``K v = ω² M v`` (rigid modes dropped)."""
        w2 = eigh(self.stiffness_matrix, self.mass_matrix, eigvals_only=True)
        n_rigid = self.rigid_modes().shape[1]
        return np.sqrt(np.clip(w2[n_rigid:], 0.0, None)) / (2 * np.pi)


def _incidence(springs: Sequence[Spring], idx: Mapping[str, int], n_bodies: int
               ) -> np.ndarray:
    """:meth:`Mechanism.incidence_vector` of each spring as rows, the body index given."""
    g = np.zeros((len(springs), n_bodies))
    for i, spring in enumerate(springs):
        for name, coef in spring.incidence.items():
            if name in idx:
                g[i, idx[name]] += coef
    return g
