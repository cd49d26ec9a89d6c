"""Subspace identification: PBSID-opt (closed-loop capable), PO-MOESP and N4SID.

Pure numerics on input/output arrays of shape (samples,) or (samples, channels), built on
numpy, scipy and the LTI core :mod:`gbpipe.lti`. Memory is O(N) in the record length: the
block-Hankel data matrix is never formed; its Gram matrix comes from lagged correlations
(or its triangular factor is accumulated in chunks), and the ``B, D`` regression of
MOESP/N4SID keeps only the Gram matrix of its regressors.

Modules, one concept each (``docs/architecture.md``, "Package map"):

* :mod:`.method_pbsid`, :mod:`.method_moesp`, :mod:`.method_n4sid`: the three methods (named
  so that no module hides its function); :mod:`.open_loop` holds
  the steps and the signature MOESP and N4SID share; :mod:`.input_matrices`: their ``B, D``
  for the estimated ``A, C``;
* :mod:`.subspace_model`: the result, :class:`SubspaceModel` (its deterministic part is a
  :class:`gbpipe.lti.NamedSS`);
* :mod:`.checks`: argument checks and the validated, channel-scaled record;
* :mod:`.excitation`: the persistent-excitation check (:class:`gbpipe.errors.ExcitationError`);
* :mod:`.hankel`: Gram matrix and triangular factor of the data windows, least squares on it;
* :mod:`.order`: order from the singular values;
* :mod:`.kalman`: steady-state Kalman gain of the innovation form;
* :mod:`.bd_regressors`: the simulated regressors of the ``B, D`` least squares;
* :mod:`.uncertainty`: jackknife confidence bounds of an identified FRF (:func:`frf_bounds`);
* :mod:`.stabilization`: stabilization diagram over many orders, modes without a model
  order (:func:`stabilization_diagram`); :mod:`.join_diagrams`: several diagrams read as one
  (:func:`join_poles`, zoom); :mod:`.lscf`: the same from an FRF by
  poly-reference LSCF (:func:`lscf_stabilization`).

Every method accepts several records (experiments) as lists, ``u = [u_0, u_1]``,
``y = [y_0, y_1]``: each record keeps its own initial state and no data window straddles
two records.

>>> model = pbsid(u, y, order="auto", past=40, dt=1e-3)          # doctest: +SKIP
>>> model.frf(freq_hz), model.fit(u_val, y_val), model.ss        # doctest: +SKIP
"""

from gbpipe.sysid.excitation import InputRank, input_hankel_rank
from gbpipe.sysid.join_diagrams import join_poles, select_poles
from gbpipe.sysid.lscf import lscf_stabilization
from gbpipe.sysid.method_moesp import moesp
from gbpipe.sysid.method_n4sid import n4sid
from gbpipe.sysid.method_pbsid import pbsid
from gbpipe.sysid.nonparametric import (
    CoherentBand,
    NonparametricFRF,
    coherent_band,
    equivalent_averages,
    welch_frf,
)
from gbpipe.sysid.stabilization import (
    Mode,
    Stabilization,
    held_modes,
    lowest_order,
    stabilization_diagram,
    stabilize,
)
from gbpipe.sysid.subspace_model import SubspaceModel
from gbpipe.sysid.uncertainty import FRFBounds, frf_bounds

__all__ = ["pbsid", "moesp", "n4sid", "SubspaceModel", "InputRank", "input_hankel_rank",
           "welch_frf", "NonparametricFRF", "coherent_band", "CoherentBand",
           "equivalent_averages", "frf_bounds", "FRFBounds", "stabilization_diagram",
           "Stabilization", "Mode", "lscf_stabilization", "lowest_order", "held_modes",
           "join_poles", "select_poles", "stabilize"]
