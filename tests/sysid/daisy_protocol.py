"""Loader and evaluation protocol for the DaISy measured records (test fixture).

DaISy is the KU Leuven identification database; the records the tests use are vendored in
``tests/data/daisy`` (origin, citation and terms in ``tests/data/daisy/SOURCE.md``).

Protocol (:func:`run_protocol`), fixed before looking at any test-segment number:

1. **Split** the record in time: estimation = first 60 %, selection = next 20 %,
   test = last 20 %.
2. **Offsets**: the estimation-segment mean of every channel is removed from the whole record
   (the models are linear; no other detrending).
3. **Order scan**: one model per order 1..12 on the estimation segment (``feedthrough=True``:
   e.g. an acceleration output responds instantly to torque). Unstable models are discarded.
4. **Order choice** on the selection segment: the smallest order whose mean simulation fit is
   within 0.5 percentage points of the best one (parsimony).
5. **Initial state**: on every evaluation segment ``x0`` is fitted by least squares
   (:meth:`SubspaceModel.estimate_x0`), so a transient does not count as model error.
6. **Report** the simulation fit ``100 (1 - ||y - y_sim|| / ||y - mean y||)`` per output on the
   test segment, which played no part in any choice.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gbpipe.sysid import SubspaceModel, moesp, n4sid, pbsid

#: The vendored records.
DATA = Path(__file__).resolve().parents[1] / "data" / "daisy"

__all__ = ["DAISY_RECORDS", "DaisyRecord", "ProtocolResult", "load_daisy", "run_protocol"]


@dataclass(frozen=True)
class DaisyRecord:
    """Column layout of one DaISy file (0-based columns) and its sample time in seconds."""

    inputs: tuple[int, ...]
    outputs: tuple[int, ...]
    dt: float
    description: str


DAISY_RECORDS: dict[str, DaisyRecord] = {
    # The header gives no sample time for these two; dt = 1 means "per sample".
    "robot_arm": DaisyRecord((0,), (1,), 1.0, "flexible robot arm, torque -> acceleration"),
    "CD_player_arm": DaisyRecord(
        (0, 1), (2, 3), 1.0, "CD-player arm, 2 actuator forces -> 2 tracking signals"
    ),
}

_METHODS: dict[str, Callable[..., SubspaceModel]] = {
    "pbsid": pbsid, "moesp": moesp, "n4sid": n4sid,
}
_DEFAULT_WINDOWS = {"pbsid": {"past": 20, "future": 10}, "moesp": {"horizon": 10},
                    "n4sid": {"horizon": 10}}


def load_daisy(name: str, root: str | Path = DATA) -> tuple[np.ndarray, np.ndarray, float]:
    """Load a DaISy record as ``(u, y, dt)`` with shapes (N, m), (N, l) and dt in seconds.

    Parameters
    ----------
    name : str
        A key of :data:`DAISY_RECORDS` (file ``<root>/<name>.dat``).
    root : str or Path
        Folder holding the ``.dat`` files; the vendored copies by default.

    Raises
    ------
    ValueError
        Unknown record name.
    FileNotFoundError
        The file is not in ``root``.
    """
    if name not in DAISY_RECORDS:
        raise ValueError(f"unknown DaISy record {name!r}; choose one of {sorted(DAISY_RECORDS)}")
    path = Path(root) / f"{name}.dat"
    if not path.is_file():
        raise FileNotFoundError(
            f"DaISy file {path} not found; the vendored records are in {DATA} "
            "(see SOURCE.md there)"
        )
    rec = DAISY_RECORDS[name]
    data = np.loadtxt(path)
    return data[:, list(rec.inputs)], data[:, list(rec.outputs)], rec.dt


@dataclass(frozen=True)
class ProtocolResult:
    """Outcome of :func:`run_protocol`.

    Attributes
    ----------
    model : SubspaceModel
        Model of the chosen order (identified on the estimation segment).
    order : int
    selection_fit, test_fit : ndarray, shape (l,)
        Simulation fit in percent per output on the selection / test segment.
    scan : dict[int, float]
        Mean selection fit per scanned stable order.
    """

    model: SubspaceModel
    order: int
    selection_fit: np.ndarray
    test_fit: np.ndarray
    scan: dict[int, float]


def run_protocol(
    u: np.ndarray,
    y: np.ndarray,
    method: str = "pbsid",
    dt: float = 1.0,
    orders: Iterable[int] = range(1, 13),
    windows: dict | None = None,
) -> ProtocolResult:
    """Run the documented DaISy protocol (module docstring) for one method.

    Parameters
    ----------
    u, y : ndarray, shapes (N, m), (N, l)
        Record (not modified).
    method : {"pbsid", "moesp", "n4sid"}
    dt : float
        Sample time in seconds.
    orders : iterable of int
        Orders to scan.
    windows : dict, optional
        Window arguments of the method; default ``past=20, future=10`` (PBSID) or
        ``horizon=10`` (MOESP/N4SID).

    Returns
    -------
    ProtocolResult

    Raises
    ------
    ValueError
        Unknown method, or no scanned order gave a stable model.
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {sorted(_METHODS)}, got {method!r}")
    fn = _METHODS[method]
    win = dict(_DEFAULT_WINDOWS[method] if windows is None else windows)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    n = u.shape[0]
    a, b = int(0.6 * n), int(0.8 * n)
    u = u - u[:a].mean(axis=0)
    y = y - y[:a].mean(axis=0)
    scan: dict[int, float] = {}
    models: dict[int, SubspaceModel] = {}
    for order in orders:
        try:
            model = fn(u[:a], y[:a], order, dt=dt, feedthrough=True, **win)
        except ValueError:
            continue  # order beyond what the windows/data allow
        if not model.is_stable():
            continue
        scan[order] = float(np.mean(model.fit(u[a:b], y[a:b])))
        models[order] = model
    if not scan:
        raise ValueError("no scanned order gave a stable model; widen `orders` or `windows`")
    best = max(scan.values())
    order = min(k for k, v in scan.items() if v >= best - 0.5)
    model = models[order]
    return ProtocolResult(
        model=model,
        order=order,
        selection_fit=model.fit(u[a:b], y[a:b]),
        test_fit=model.fit(u[b:], y[b:]),
        scan=scan,
    )
