"""Subspace identification: PBSID-opt (closed-loop capable), PO-MOESP and N4SID.

Pure numerics on input/output arrays of shape (samples,) or (samples, channels). Memory is
O(N) in the record length: the block-Hankel data matrix is never formed; its triangular
factor is accumulated in chunks (see ``_common.window_r_factor``).

>>> model = pbsid(u, y, order="auto", past=40, dt=1e-3)          # doctest: +SKIP
>>> model.frf(freq_hz), model.fit(u_val, y_val), model.to_statespace()  # doctest: +SKIP
"""

from .moesp import moesp
from .n4sid import n4sid
from .pbsid import pbsid
from .result import SubspaceModel, simulate_ss

__all__ = ["pbsid", "moesp", "n4sid", "SubspaceModel", "simulate_ss"]
