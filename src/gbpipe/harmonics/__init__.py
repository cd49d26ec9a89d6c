"""Harmonic removal on real and virtual tachometers: from pulses to TSA residuals and
their metrics (docs/architecture.md, "Package map").

Modules, each one concept, lowest first:

=================  ======================================================================
``checks``         argument and data checks shared by all (DataError / PulseError)
``tacho``          tachometer pulses: detection, checks and repair, shaft angle and speed
``angle``          angular resampling to and from constant shaft angle (:class:`AngleMap`)
``tracking``       order-tracked complex amplitudes at exact orders
``binning``        speed bins shared by spectra and metrics
``spectra``        power and order spectra vs rpm (waterfalls), order spectrum of a record
``averaging``      one family's cycle plan: block, sliding and quadratic averages
``tsa``            time-synchronous averaging residuals: one family
``joint``          several families at once: backfitting or cascade
``least_change``   the least-changing pass of a backfitting, and when its passes diverge
``pieces``         a removal of an hour-long record in overlapping pieces (bounded memory)
``families``       exact cycle orders, excitation families, structural modes
``metrics``        family attenuation, mode-band change, removal metrics
``stage``          what the workflow calls (spectra, tsa, removal_tests stages)
=================  ======================================================================

Removal beyond TSA (issue 16):

=====================  =====================================================================
``removal_inputs``     checked inputs shared by the methods below
``vkf``                Vold-Kalman order tracking filter, second generation, joint orders
``vkf_report``         what a VKF run tells: crowded orders, one warning for all its pieces
``amplitude_basis``    the regression's amplitude basis in time, and its fit's reach
``regression``         angle-domain least-squares regression, slowly varying amplitudes
                       (and the swept modal response of orders crossing a mode)
``regression_design``  the regression's blocks: cuts at the knots, local design
                       matrices, the modal carriers' border columns
``crossings``          order/mode crossings: half-power bands, swept modal carriers, marks
``shaft_angles``       the second line-carrying shaft's angle: twist from the two speeds
``drs``                discrete/random separation in the angle domain
``cepstrum``           cepstral editing: comb liftering of the families' rahmonics
``removal``            every method behind one signature (``METHODS``: tsa, vkf, ...)
``separation``         exact separation metric: attenuation, distortion vs random-only
``comparison``         what the workflow calls: every method on the sweep, scored
                       (``removal``, ``removal_table``), and on the tests (``removal_tests``)
=====================  =====================================================================

Imports only numpy, scipy, xarray and gbpipe's kinematics, units, errors and progress
lines, and (in ``stage`` and ``comparison``) the record contract of :mod:`gbpipe.io` (the
measured form of a signal, the tacho shaft's mean speed, the longest gap-free piece):
never the bench model or the simulator, so that it runs unchanged on measured records.
"""

from gbpipe.harmonics.angle import AngleMap, resample_to_angle, resample_to_time
from gbpipe.harmonics.averaging import AVERAGING, CyclePlan
from gbpipe.harmonics.cepstrum import residual_cepstrum
from gbpipe.harmonics.comparison import (
    compare_method,
    harmonic_record,
    method_params,
    method_residuals,
    record_params,
    record_separation,
    removal_rows,
)
from gbpipe.harmonics.crossings import crossing_marks, half_power_band, modal_carriers
from gbpipe.harmonics.drs import residual_drs
from gbpipe.harmonics.families import (
    cycle_orders,
    excitation_families,
    family_names,
    family_orders,
    removed_families,
    structural_modes,
    test_families,
)
from gbpipe.harmonics.joint import JointInfo, residual_joint
from gbpipe.harmonics.metrics import family_attenuation, mode_band_change, removal_metrics
from gbpipe.harmonics.regression import residual_regression
from gbpipe.harmonics.removal import METHODS as REMOVAL_METHODS
from gbpipe.harmonics.removal import family_cycles, remove_harmonics, residual_tsa
from gbpipe.harmonics.separation import separation_metrics
from gbpipe.harmonics.shaft_angles import shaft_twist
from gbpipe.harmonics.spectra import order_spectrum, order_spectrum_vs_rpm, power_spectrum_vs_rpm
from gbpipe.harmonics.stage import (
    envelope_modes,
    record_residuals,
    remove,
    split_residuals,
    sweep_waterfalls,
    tsa_variant,
    variant_metrics,
    waterfalls,
)
from gbpipe.harmonics.tacho import (
    PulseCheck,
    check_pulse_times,
    pulse_times_from_tacho,
    shaft_angle,
    shaft_speed,
)
from gbpipe.harmonics.tracking import order_amplitudes
from gbpipe.harmonics.tsa import TSAInfo, residual
from gbpipe.harmonics.vkf import residual_vkf

__all__ = [
    # tachometer and angle
    "pulse_times_from_tacho", "check_pulse_times", "PulseCheck", "shaft_angle",
    "shaft_speed", "AngleMap", "resample_to_angle", "resample_to_time",
    # spectra and order tracking
    "power_spectrum_vs_rpm", "order_spectrum_vs_rpm", "order_spectrum", "order_amplitudes",
    # time-synchronous averaging
    "residual", "residual_joint", "TSAInfo", "JointInfo",
    "CyclePlan", "AVERAGING",
    # families and metrics
    "family_orders", "cycle_orders", "family_names", "excitation_families",
    "removed_families", "test_families",
    "structural_modes", "family_attenuation", "mode_band_change", "removal_metrics",
    # removal methods beyond TSA, and their exact separation metric
    "REMOVAL_METHODS", "remove_harmonics", "residual_tsa", "residual_vkf",
    "residual_regression", "residual_drs", "residual_cepstrum", "family_cycles",
    "separation_metrics", "modal_carriers", "half_power_band", "crossing_marks",
    # workflow stages
    "remove", "waterfalls", "variant_metrics", "sweep_waterfalls", "tsa_variant",
    "record_residuals", "split_residuals", "compare_method", "method_params",
    "record_params", "shaft_twist",
    "envelope_modes",
    "method_residuals", "removal_rows", "record_separation", "harmonic_record",
]
