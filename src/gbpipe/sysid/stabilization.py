"""Stabilization diagrams: modes read off models of many orders, without a model order.

A physical mode shows at (nearly) the same frequency, damping and shape in models of every
order that is large enough to hold it; a pole that fits noise moves from order to order.
The field's practice (SSI with stabilization charts: Peeters & De Roeck, MSSP 13, 1999;
PolyMAX: Peeters, Van der Auweraer, Guillaume & Leuridan, Shock Vib. 11, 2004) is to fit a
range of orders, flag the poles that stay put between consecutive orders, group the flagged
poles into clusters (as pyOMA2 and sdypy-EMA do: hierarchical clustering of the frequency
distances, one pole per order and cluster, a minimum cluster size relative to the orders
that can hold the mode) and report each cluster as a mode. The model order is the lowest
whose poles hold every cluster. :func:`stabilization_diagram` reads every order off one
projection and SVD of a subspace method (:func:`gbpipe.sysid.method_pbsid.pbsid_orders`,
:func:`gbpipe.sysid.open_loop.open_loop_orders`); :func:`gbpipe.sysid.lscf_stabilization`
(:mod:`.lscf`) feeds the same :func:`stabilize` from a frequency-domain fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import pdist

from gbpipe.errors import ConfigError
from gbpipe.sysid.checks import channel_counts, check_dt
from gbpipe.sysid.method_pbsid import pbsid_orders
from gbpipe.sysid.open_loop import open_loop_orders

__all__ = ["Mode", "Stabilization", "stabilization_diagram", "stabilize", "continuous_poles",
           "check_orders", "check_criteria", "mac", "lowest_order", "held_modes"]

PoleSet = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Mode:
    """One cluster of stable poles: a mode of the data.

    Attributes
    ----------
    frequency_hz : float
        Median undamped natural frequency of the cluster [Hz].
    damping : float
        Median damping ratio [1].
    frequency_spread_hz : float
        Standard deviation of the frequency over the cluster [Hz].
    damping_spread : float
        Standard deviation of the damping ratio [1].
    n_orders : int
        Number of model orders the mode appears in (stable) [1].
    shape : ndarray, complex
        Mode shape of the member nearest the median frequency, largest component 1 (output
        units for a subspace diagram; participation vector over the inputs for LSCF).
    """

    frequency_hz: float
    damping: float
    frequency_spread_hz: float
    damping_spread: float
    n_orders: int
    shape: np.ndarray


@dataclass(frozen=True)
class Stabilization:
    """A stabilization diagram and the modes read off it.

    Attributes
    ----------
    orders : ndarray of int
        Model orders fitted, ascending (state dimension for a subspace method, polynomial
        order for LSCF).
    poles : list of (frequency_hz, damping, shape)
        Per order, the physical poles (one per conjugate pair), ascending in frequency:
        frequency [Hz] and damping ratio [1] arrays, shapes (poles, channels) complex.
    stable : list of ndarray of bool
        Per order, which poles match a pole of the previous order within the criteria.
    labels : list of ndarray of int
        Per order, the index in ``clusters`` of each pole, -1 for none.
    clusters : list of Mode
        The modes, ascending in frequency.
    candidates : list of Mode
        Clusters of 3 orders or more too small to be modes (``min_share``), ascending in
        frequency: noise that stayed put a while, or modes that the largest orders fitted
        only begin to hold (then extend the orders).
    order : int
        Lowest order whose poles hold every cluster; 0 when no mode was found.
    method : str
    """

    orders: np.ndarray
    poles: list[PoleSet]
    stable: list[np.ndarray]
    labels: list[np.ndarray]
    clusters: list[Mode]
    candidates: list[Mode]
    order: int
    method: str


def check_orders(orders: object) -> np.ndarray:
    """``orders`` as a strictly increasing int array of at least 2 orders >= 1; else a
    ConfigError (field ``orders``)."""
    arr = np.asarray(orders)
    if arr.ndim != 1 or arr.size < 2 or not np.issubdtype(arr.dtype, np.integer):
        raise ConfigError("orders", "must be a 1-D list of at least 2 integers, e.g. "
                          f"range(2, 61, 2); got {orders!r}")
    if arr[0] < 1 or np.any(np.diff(arr) <= 0):
        raise ConfigError("orders", f"must be >= 1 and strictly increasing, got {arr.tolist()}")
    return arr.astype(int)


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Modal assurance criterion between the rows of ``a`` (p, k) and of ``b`` (q, k).

    Returns
    -------
    ndarray, shape (p, q)
        ``|a_i^H b_j|^2 / (|a_i|^2 |b_j|^2)`` in [0, 1].
    """
    num = np.abs(a.conj() @ b.T) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=1), np.sum(np.abs(b) ** 2, axis=1))
    return num / np.where(den > 0, den, 1.0)


def continuous_poles(z: np.ndarray, shapes: np.ndarray, dt: float, max_damping: float
                     ) -> PoleSet:
    """Physical poles of discrete eigenvalues ``z`` with their shapes (columns).

    ``s = log(z) / dt``; kept are poles of positive imaginary part (one per conjugate pair,
    no real poles), damping ratio in ``[0, max_damping]`` and natural frequency below
    Nyquist ``1 / (2 dt)``. Shapes are scaled so that their largest component is 1.

    Returns
    -------
    frequency_hz, damping, shape
        Ascending in frequency; ``shape`` (poles, channels).
    """
    s = np.log(np.where(np.abs(z) < 1e-300, 1e-300, z).astype(complex)) / dt
    wn = np.abs(s)
    zeta = -s.real / np.where(wn > 0, wn, 1.0)
    keep = ((s.imag > 1e-9 * np.pi / dt) & (zeta >= 0) & (zeta <= max_damping)
            & (wn < np.pi / dt))
    idx = np.flatnonzero(keep)
    idx = idx[np.argsort(wn[idx])]
    phi = shapes[:, idx].T
    big = phi[np.arange(idx.size), np.argmax(np.abs(phi), axis=1)] if idx.size else 1.0
    return wn[idx] / (2 * np.pi), zeta[idx], phi / np.atleast_1d(big)[:, None]


def _matches(a: PoleSet, b: PoleSet, freq_tol: float, damping_tol: float, mac_min: float
             ) -> np.ndarray:
    """(poles of a, poles of b) bool: same mode within the criteria."""
    fa, za, pa = a
    fb, zb, pb = b
    ok = np.abs(fa[:, None] - fb[None, :]) <= freq_tol * fb[None, :]
    ok &= np.abs(za[:, None] - zb[None, :]) <= damping_tol * zb[None, :]
    if pa.shape[1] > 1:  # one channel: every shape is the same scalar
        ok &= mac(pa, pb) >= mac_min
    return ok


def stabilize(orders: np.ndarray, poles: list[PoleSet], method: str, *,
              frequency_tolerance: float = 0.01, damping_tolerance: float = 0.05,
              mac_min: float = 0.95, min_share: float = 0.5) -> Stabilization:
    """Stability flags, clusters and order of a stabilization diagram.

    Parameters
    ----------
    orders : ndarray of int
        Ascending model orders.
    poles : list of (frequency_hz, damping, shape)
        Physical poles per order (:func:`continuous_poles`).
    method : str
        Name recorded in the result.
    frequency_tolerance : float
        Largest relative frequency change between consecutive orders of a stable pole [1].
    damping_tolerance : float
        Largest relative damping change [1].
    mac_min : float
        Smallest MAC between the shapes at consecutive orders (ignored with one channel).
    min_share : float
        A cluster is a mode when it appears in this share of the orders that can hold it
        (from the first with a pole at its frequency) or of the largest cluster's, the
        fewer, and in 3 orders at least; the orders that can hold it must reach this share
        of those that can hold the largest (:func:`_is_mode`): a pole fitting noise stays
        put over a few orders only, a mode over every order that can hold it.

    Returns
    -------
    Stabilization
    """
    tol = (frequency_tolerance, damping_tolerance, mac_min)
    stable = [np.zeros(poles[0][0].size, dtype=bool)]
    for prev, cur in zip(poles[:-1], poles[1:], strict=True):
        stable.append(_matches(cur, prev, *tol).any(axis=1))
    members = [(k, i) for k in range(len(orders)) for i in np.flatnonzero(stable[k])]
    labels = [np.full(p[0].size, -1) for p in poles]
    modes: list[Mode] = []
    candidates: list[Mode] = []
    if members:
        groups = _cluster(poles, members, frequency_tolerance)
        best = max(groups, key=len)
        for group in groups:
            if _is_mode(poles, group, best, frequency_tolerance, min_share):
                for k, i in group:
                    labels[k][i] = len(modes)
                modes.append(_mode(poles, group))
            elif len(group) >= 3:
                candidates.append(_mode(poles, group))
    rank = np.argsort([m.frequency_hz for m in modes])
    modes = [modes[j] for j in rank]
    relabel = np.append(np.argsort(rank), -1)  # old index -> new; -1 stays -1
    labels = [relabel[lab] for lab in labels]
    order = lowest_order(orders, poles, modes, frequency_tolerance)
    candidates.sort(key=lambda m: m.frequency_hz)
    return Stabilization(orders=orders, poles=poles, stable=stable, labels=labels,
                         clusters=modes, candidates=candidates, order=order, method=method)


def _cluster(poles: list[PoleSet], members: list[tuple[int, int]], freq_tol: float
             ) -> list[list[tuple[int, int]]]:
    """Average-linkage clusters of the stable poles by frequency, one pole per order in each.

    The distance of two poles is their log-frequency difference (the relative difference,
    symmetric); the tree is cut at ``log(1 + freq_tol)``. Shapes already entered the
    stability test, and a second distance on them split one mode into two clusters when
    an over-fitted order carries a twin of a pole (LSCF at high orders); so a cluster
    keeps, per order, the pole nearest its median frequency and the twin stays
    unlabelled. Two modes closer than ``freq_tol`` become one (the limit of the
    criterion, as in sdypy-EMA's frequency-only test).
    """
    f = np.array([poles[k][0][i] for k, i in members])
    if len(members) == 1:
        return [members]
    tree = linkage(pdist(np.log(f)[:, None], "cityblock"), method="average")
    label = fcluster(tree, t=np.log1p(freq_tol), criterion="distance")
    groups = []
    for c in np.unique(label):
        idx = np.flatnonzero(label == c)
        med = np.median(f[idx])
        best: dict[int, int] = {}
        for j in idx[np.argsort(np.abs(f[idx] - med))]:
            best.setdefault(members[j][0], j)
        groups.append(sorted(members[j] for j in best.values()))
    return groups


def _is_mode(poles: list[PoleSet], group: list[tuple[int, int]],
             best: list[tuple[int, int]], freq_tol: float, min_share: float) -> bool:
    """Whether a cluster of stable poles is held by enough orders to be a mode: in
    ``min_share`` of the largest cluster ``best``'s orders (pyOMA2's relative size), or in
    ``min_share`` of the orders that can hold it, from the one with room for it
    (:func:`_room`; a heavily damped or weakly participating mode enters late), when those
    reach ``min_share`` of ``best``'s (a pole entering near the top has too few orders
    left to tell a mode from noise that stayed put a while). 3 orders at least."""
    if len(group) >= max(3, int(np.ceil(min_share * len(best)))):
        return True
    room = _room(poles, group, freq_tol)
    return (room >= min_share * _room(poles, best, freq_tol)
            and len(group) >= max(3, int(np.ceil(min_share * room))))


def _room(poles: list[PoleSet], group: list[tuple[int, int]], freq_tol: float) -> int:
    """Orders from the first with a pole near the cluster's median (stable or not) on."""
    f = np.median([poles[k][0][i] for k, i in group])
    return len(poles) - int(np.argmax(_held(poles, np.array([f]), freq_tol)[:, 0]))


def _mode(poles: list[PoleSet], group: list[tuple[int, int]]) -> Mode:
    """Median, spread and representative shape of one cluster. The median, not the mean:
    the stability test bounds the change between consecutive orders only, so a few members
    can carry a damping far from the rest (twice the median on a mode near the noise)."""
    f = np.array([poles[k][0][i] for k, i in group])
    z = np.array([poles[k][1][i] for k, i in group])
    k0, i0 = group[int(np.argmin(np.abs(f - np.median(f))))]
    return Mode(frequency_hz=float(np.median(f)), damping=float(np.median(z)),
                frequency_spread_hz=float(f.std()), damping_spread=float(z.std()),
                n_orders=len(group), shape=poles[k0][2][i0].copy())


def lowest_order(orders: np.ndarray, poles: list[PoleSet], modes: list[Mode] | np.ndarray,
                 freq_tol: float) -> int:
    """Lowest order with a pole within the frequency tolerance of every mode.

    ``modes``: :class:`Mode` objects, or their frequencies [Hz] (modes another diagram
    found).

    Damping and shape are not asked for: at the lowest order that holds a mode they are
    often still moving (LSCF participation vectors most of all), while its frequency is
    already there.
    """
    fm = np.array([getattr(m, "frequency_hz", m) for m in modes], dtype=float)
    if not fm.size:
        return 0
    for n, held_here in zip(orders, _held(poles, fm, freq_tol), strict=True):
        if held_here.all():
            return int(n)
    return int(orders[-1])


def _held(poles: list[PoleSet], fm: np.ndarray, freq_tol: float) -> np.ndarray:
    """(order, mode) whether the order has a pole within the tolerance of the mode."""
    return np.array([(np.abs(f[None, :] - fm[:, None]) <= freq_tol * fm[:, None]).any(axis=1)
                     if f.size else np.zeros(fm.size, bool) for f, _, _ in poles],
                    dtype=bool).reshape(len(poles), fm.size)


def held_modes(poles: list[PoleSet], modes: np.ndarray, freq_tol: float) -> np.ndarray:
    """Which modes [Hz] (e.g. another diagram's) some order of this diagram holds.

    A mode no order holds cannot set this diagram's order: asking for it would only
    push the order to the highest tried (and a model of that order fits noise).
    """
    fm = np.asarray(modes, dtype=float)
    return _held(poles, fm, freq_tol).any(axis=0) if len(poles) else np.zeros(fm.size, bool)


def state_poles(amat: np.ndarray, cmat: np.ndarray, dt: float, max_damping: float) -> PoleSet:
    """Physical poles of a discrete state-space pair ``(A, C)``; shapes ``C v``."""
    z, v = np.linalg.eig(amat)
    return continuous_poles(z, cmat @ v, dt, max_damping)


def stabilization_diagram(u: object, y: object, dt: float, orders: object,
                          method: str = "pbsid", *, frequency_tolerance: float = 0.01,
                          damping_tolerance: float = 0.05, mac_min: float = 0.95,
                          max_damping: float = 0.2, min_share: float = 0.5,
                          **settings: object) -> Stabilization:
    """Stabilization diagram of a subspace method over a range of orders.

    The projection and SVD are computed once; every order reads its ``A, C`` off them
    (as SSI does) and gives exactly the poles of the method fitted at that order.

    Parameters
    ----------
    u, y : array_like or list of arrays
        Input and output records, shapes (N,) or (N, channels), any units.
    dt : float
        Sample time [s].
    orders : sequence of int
        State dimensions, strictly increasing, e.g. ``range(2, 61, 2)``.
    method : {"pbsid", "moesp", "n4sid"}
    frequency_tolerance, damping_tolerance, mac_min, min_share
        Stability and cluster criteria (:func:`stabilize`); MAC on the output shapes
        ``C v`` in output units, used when there are several outputs.
    max_damping : float
        Poles with a larger damping ratio are dropped as not physical [1].
    **settings
        Windows and options of the method: ``past``, ``future``, ``regularization``,
        ``feedthrough``, ``factor`` (PBSID); ``horizon``, ``past``, ``factor``
        (MOESP/N4SID). Default window: the fewest block rows that allow the largest order
        (``ceil(max order / outputs)``, +1 for MOESP/N4SID); lightly damped data usually
        need a longer ``past`` (docs/sysid.md).

    Returns
    -------
    Stabilization

    Raises
    ------
    ConfigError
        Bad ``orders``, ``method`` or criteria; an order beyond what the windows allow.
    DataError, ExcitationError
        As the subspace methods.
    """
    orders = check_orders(orders)
    dt = check_dt(dt)
    check_criteria(frequency_tolerance, damping_tolerance, mac_min, max_damping, min_share)
    _, n_out = channel_counts(u, y)
    rows = -(-int(orders[-1]) // n_out)
    if method == "pbsid":
        future = settings.pop("future", rows)
        past = settings.pop("past", max(rows, int(future)))
        pairs = pbsid_orders(u, y, orders, past, future, dt, **settings)
    elif method in ("moesp", "n4sid"):
        horizon = settings.pop("horizon", rows + 1)
        past = settings.pop("past", None)
        pairs = open_loop_orders(u, y, orders, horizon, dt, past, method, **settings)
    else:
        raise ConfigError("method", f"must be 'pbsid', 'moesp' or 'n4sid', got {method!r}")
    poles = [state_poles(a, c, dt, max_damping) for a, c in pairs]
    return stabilize(orders, poles, method, frequency_tolerance=frequency_tolerance,
                     damping_tolerance=damping_tolerance, mac_min=mac_min,
                     min_share=min_share)


def check_criteria(frequency_tolerance: float, damping_tolerance: float, mac_min: float,
                   max_damping: float, min_share: float) -> None:
    """Refuse criteria outside their meaningful ranges (ConfigError naming the field)."""
    for name, value, low, high in (("frequency_tolerance", frequency_tolerance, 0, 1),
                                   ("damping_tolerance", damping_tolerance, 0, 10),
                                   ("mac_min", mac_min, 0, 1),
                                   ("max_damping", max_damping, 0, 1),
                                   ("min_share", min_share, 0, 1)):
        if not (np.isfinite(value) and low < value <= high):
            raise ConfigError(name, f"must be in ({low}, {high}], got {value!r}")
