"""Noise covariances of a virtual sensor from the record itself: maximum likelihood on the
innovations of the steady-state Kalman filter.

Parameters: the log standard deviation of each measured channel's noise, of each motor
torque's noise (process noise through ``B``), the log intensity of each unknown load's
random walk and the log level of a white torque on every coordinate (the model's error)
(:class:`gbpipe.virtual.smoother.NoiseModel`). A common scale of all of them leaves the
gains unchanged and is concentrated out of the Gaussian likelihood (its estimate
``Σ eᵀS⁻¹e / (N p)`` is applied at the end), so the first channel's level is held and the
others are searched (``scipy.optimize.minimize``, L-BFGS-B, on a log scale ±12 around a
start from the data: each signal's sample-to-sample difference, ``sd(Δx)/√2``, an upper
bound of its white noise), and from process noise (load walks and model error) two decades
below and above it, the best of the three kept: the likelihood has more than one optimum
in those levels. The offsets and the initial state are estimated inside every
evaluation (generalised least squares, :func:`gbpipe.virtual.smoother.innovations`), so
they never pass for noise. The window of the record the likelihood reads is the caller's
(``virtual.noise.window``), reported with the result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from gbpipe.errors import DataError
from gbpipe.virtual.model import EstimationModel
from gbpipe.virtual.smoother import NoiseModel, gains, innovations

__all__ = ["NoiseFit", "fit_noise", "neg2_loglik"]

#: Search range of each log parameter around its start [-] (e¹² ≈ 1.6e5).
_LOG_RANGE = 12.0
#: Decades of the process-noise levels (load walks and model error) between the starts of
#: the likelihood search [-]: within the search range, far enough apart to start in
#: another basin (:func:`fit_noise`).
_PROCESS_DECADES = 2.0


@dataclass
class NoiseFit:
    """The maximum-likelihood noise model.

    Attributes
    ----------
    noise : NoiseModel
        Absolute levels (the concentrated scale applied).
    neg2_loglik_per_sample : float
        −2 log-likelihood per sample at the optimum [-].
    evaluations : int
        Likelihood evaluations.
    converged : bool
        The optimizer's own success flag.
    message : str
        The optimizer's message.
    """

    noise: NoiseModel
    neg2_loglik_per_sample: float
    evaluations: int
    converged: bool
    message: str


def _split(model: EstimationModel, v: np.ndarray) -> NoiseModel:
    p, m = len(model.measured), len(model.inputs)
    s = np.exp(v)
    return NoiseModel(s[:p], s[p:p + m], s[p + m:-1], float(s[-1]))


def neg2_loglik(model: EstimationModel, noise: NoiseModel, y: np.ndarray, u: np.ndarray
                ) -> tuple[float, float]:
    """−2 log-likelihood per sample of ``(y, u)`` with the scale concentrated out, and
    that scale [-]."""
    g = gains(model, noise)
    _, _, rss = innovations(model, g, y, u)
    N, p = y.shape
    scale = rss / (N * p)
    return float(np.linalg.slogdet(g.S)[1] + p * np.log(scale) + p), scale


def fit_noise(model: EstimationModel, y: np.ndarray, u: np.ndarray) -> NoiseFit:
    """Maximum-likelihood noise levels of ``model`` on a record (module docstring).

    Parameters
    ----------
    y : ndarray (N, p)
        Measured channels [their units].
    u : ndarray (N, m)
        Motor torques [N·m].

    Raises
    ------
    gbpipe.errors.DataError
        A constant channel (no start level), or no finite likelihood at the start.
    """
    dt = model.dt
    for name, x in zip([*model.measured, *model.inputs], np.hstack([y, u]).T, strict=True):
        if not np.std(np.diff(x)) > 0:
            raise DataError(name, "constant over the noise window: no noise level can be "
                            "estimated; choose another virtual.noise.window or sensor")
    start_y = np.std(np.diff(y, axis=0), axis=0) / np.sqrt(2)
    start_u = np.std(np.diff(u, axis=0), axis=0) / np.sqrt(2)
    # a load that moves by the motor torques' own sample-to-sample change each second
    start_w = np.full(len(model.load_states), np.mean(start_u) if len(start_u) else 1.0)
    # the model error: a torque on every coordinate, a hundredth of the motors' noise
    start_m = 0.01 * (np.mean(start_u) if len(start_u) else 1.0)
    v0 = np.log(np.concatenate([start_y, start_u, start_w * np.sqrt(1.0 / dt), [start_m]]))
    count = [0]

    def cost(free: np.ndarray) -> float:
        count[0] += 1
        v = np.concatenate([v0[:1], free])
        try:
            return neg2_loglik(model, _split(model, v), y, u)[0]
        except (DataError, np.linalg.LinAlgError, ValueError):
            return 1e30

    start = cost(v0[1:])
    if not np.isfinite(start) or start >= 1e30:
        raise DataError("virtual", "the Kalman filter has no finite likelihood at the "
                        "start noise levels: check the sensors and motor torques")
    # The likelihood is not unimodal in the process-noise levels: a record's loads and
    # model error can be explained by a slow estimator (model error near zero, a slowest
    # pole of tens of seconds) or a faster one, and which optimum L-BFGS-B reaches from a
    # single start turned on the last bit of the record (the measured example simulated
    # with one or several BLAS threads). So the search starts from the data's levels and
    # from process noise _PROCESS_DECADES decades below and above them, and keeps the best.
    process = np.zeros(v0.size - 1)
    process[-(len(model.load_states) + 1):] = 1.0
    res = None
    for decades in (0.0, -_PROCESS_DECADES, _PROCESS_DECADES):
        x0 = v0[1:] + decades * np.log(10.0) * process
        if decades and cost(x0) >= 1e30:   # the data's start is known finite (above)
            continue
        # ftol: a change of 1e-7 in −2 log L per sample is far below what moves an estimate
        trial = optimize.minimize(cost, x0, method="L-BFGS-B",
                                  bounds=[(a - _LOG_RANGE, a + _LOG_RANGE) for a in v0[1:]],
                                  options={"ftol": 1e-7})
        if res is None or trial.fun < res.fun:
            res = trial
    v = np.concatenate([v0[:1], res.x])
    value, scale = neg2_loglik(model, _split(model, v), y, u)
    # the concentrated scale: every covariance times it, every sd times its root
    noise = _split(model, v + 0.5 * np.log(scale))
    return NoiseFit(noise, value, count[0], bool(res.success), str(res.message))
