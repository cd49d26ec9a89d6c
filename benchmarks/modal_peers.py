"""The peer tools of the modal benchmarks, called one way: pyOMA2 and sdypy-EMA.

Shared by ``benchmarks/modal.py`` (two fixed records) and ``benchmarks/modal_selection.py``
(random chains). Each returns ``[(frequency [Hz], damping ratio [1]), ...]`` ascending.

* :func:`pyoma2_ssicov`: pyOMA2's covariance-driven SSI on the outputs alone, its own
  stabilization and its automatic selection, hierarchical clustering with average linkage
  (``Clustering(quick="hier_avg")``).
* :func:`sdypy_lscf`: sdypy-EMA's LSCF on an H1 FRF. sdypy-EMA has no automatic
  selection: its poles are picked on the stability chart by hand (``select_poles``, a
  GUI) or near given frequencies (``select_closest_poles``), which this function does.
* :func:`measured`: result, CPU and wall time, peak traced memory of one call.
"""

from __future__ import annotations

import time
import tracemalloc
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np


def pyoma2_ssicov(y: np.ndarray, dt: float, ordmax: int, br: int = 31
                  ) -> list[tuple[float, float]]:
    """pyOMA2 SSI-cov of outputs ``y`` (N, L) sampled every ``dt`` [s], orders up to
    ``ordmax``, ``br`` block rows; its hierarchical clustering picks the modes."""
    from pyoma2.algorithms.data.run_params import Clustering  # optional dependency
    from pyoma2.algorithms.ssi import SSI  # optional dependency
    from pyoma2.setup.single import SingleSetup  # optional dependency

    setup = SingleSetup(np.array(y, copy=True), fs=1.0 / dt)
    ssi = SSI(name="ssicov", method="cov", br=br, ordmax=ordmax)
    setup.add_algorithms(ssi)
    setup.run_all()
    ssi.add_clustering(Clustering(name="hier", quick="hier_avg"))
    ssi.run_all_clustering()
    res = ssi.result.clustering_results["hier"]
    return sorted(zip(np.atleast_1d(res.Fn).tolist(), np.atleast_1d(res.Xi).tolist(),
                      strict=True))


def sdypy_lscf(frf: Any, approx_hz: Sequence[float], poles: int
               ) -> list[tuple[float, float]]:
    """sdypy-EMA LSCF on ``frf`` (``gbpipe.sysid.welch_frf``, DC dropped) up to ``poles``
    poles, its stable poles taken nearest ``approx_hz`` [Hz] (it selects no modes alone)."""
    from sdypy import EMA  # optional dependency

    h = frf.frf.reshape(frf.frf.shape[0], -1).T  # (FRFs, frequency)
    model = EMA.Model(h, frf.frequency, lower=frf.frequency[1], upper=frf.frequency[-1],
                      pol_order_high=poles // 2, frf_form="receptance")
    model.get_poles(method="lscf", show_progress=False)
    model.select_closest_poles(list(approx_hz))
    # A frequency it found no stable pole near comes back as 0: not a mode.
    return sorted((f, z) for f, z in zip(np.asarray(model.nat_freq).tolist(),
                                         np.asarray(model.nat_xi).tolist(), strict=True)
                  if f > 0)


def measured(fn: Callable[[], Any], memory: bool = True) -> tuple[Any, float, float, float]:
    """Result, CPU [s], wall [s] and peak traced memory [MiB] of ``fn()``.

    The memory comes from a second, untimed run under ``tracemalloc`` (which slows what it
    traces); NaN with ``memory=False``.
    """
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn()
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    peak = np.nan
    if memory:
        tracemalloc.start()
        fn()
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    return out, cpu, wall, peak
