"""Tachometer (toothed-wheel / encoder) pulse trains from a simulated shaft angle.

`pulse_times` turns a sampled shaft angle into the times at which each tooth passes the
pick-up, optionally with a fixed per-tooth spacing error and quantised to a counter clock,
as a pulse-timing (zero-crossing / counter) tachometer would report them.
`analog_channel` renders pulse times as a sampled square wave, e.g. to exercise an edge
detector.

Pulse geometry: tooth ``k`` (any integer, counted from angle 0) sits at angle
``theta_k = 2 pi k / ppr + eps[k mod ppr]`` [rad], where ``eps`` is the spacing (position)
error of each tooth, a fixed pattern repeating every revolution. A pulse is reported when
the angle reaches ``theta_k``, for every ``theta_k`` in ``(angle[0], angle[-1]]`` (a tooth
exactly at the initial angle passed before the record started and is not reported).
"""

from __future__ import annotations

import numpy as np

__all__ = ["pulse_times", "analog_channel", "tooth_errors"]

_NEWTON_ITER = 60


def _as_1d_finite(x: object, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        raise ValueError(f"{name} contains NaN or inf (first at sample {np.flatnonzero(bad)[0]})")
    return arr


def tooth_errors(
    pulses_per_rev: int, std_rad: float, rng: np.random.Generator | int
) -> np.ndarray:
    """Draw one fixed spacing-error pattern (one value per tooth).

    Parameters
    ----------
    pulses_per_rev : int
        Number of teeth (pulses per revolution), >= 1.
    std_rad : float
        Standard deviation of the tooth position error [rad], >= 0.
    rng : numpy.random.Generator or int
        Generator, or seed for ``numpy.random.default_rng``.

    Returns
    -------
    ndarray, shape (pulses_per_rev,)
        Position error of each tooth [rad], normal with the given std, clipped to
        ``+-0.45`` pitch so teeth never swap order.
    """
    if not np.isfinite(std_rad) or std_rad < 0:
        raise ValueError(f"spacing_error_rad (std) must be finite and >= 0 rad, got {std_rad}")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    pitch = 2 * np.pi / pulses_per_rev
    return np.clip(gen.normal(0.0, std_rad, pulses_per_rev), -0.45 * pitch, 0.45 * pitch)


def _hermite_slopes(t: np.ndarray, th: np.ndarray) -> np.ndarray:
    """Derivative estimates dθ/dt at the samples when no speed is given.

    Three-point (second-order) finite differences on the non-uniform grid, exact for a
    quadratic angle (constant acceleration), then limited Fritsch-Carlson style to
    ``[0, 3 x`` the adjacent secant slopes``]`` so the cubic Hermite interpolant stays
    monotone.
    """
    h = np.diff(t)
    sec = np.diff(th) / h
    if t.size == 2:
        return np.array([sec[0], sec[0]])
    m = np.empty_like(th)
    h0, h1 = h[:-1], h[1:]
    m[1:-1] = (h1 * sec[:-1] + h0 * sec[1:]) / (h0 + h1)
    # One-sided second-order ends.
    m[0] = ((2 * h[0] + h[1]) * sec[0] - h[0] * sec[1]) / (h[0] + h[1])
    m[-1] = ((2 * h[-1] + h[-2]) * sec[-1] - h[-1] * sec[-2]) / (h[-1] + h[-2])
    lim = np.full_like(th, np.inf)
    lim[:-1] = np.minimum(lim[:-1], 3 * sec)
    lim[1:] = np.minimum(lim[1:], 3 * sec)
    return np.clip(m, 0.0, lim)


def _invert_hermite(
    t0: np.ndarray,
    h: np.ndarray,
    delta: np.ndarray,
    m0: np.ndarray,
    m1: np.ndarray,
    r: np.ndarray,
) -> np.ndarray:
    """Solve H(s) = r on s in [0, 1] for cubic Hermite segments; return t0 + s h.

    ``H(s) = (3s^2 - 2s^3) delta + (s^3 - 2s^2 + s) m0 h + (s^3 - s^2) m1 h`` with
    ``H(0) = 0 < r <= H(1) = delta``. Newton iterations safeguarded by bisection on the
    bracket keep every iterate inside the segment even if the cubic is not monotone.
    """
    a0, a1 = m0 * h, m1 * h
    lo = np.zeros_like(r)
    hi = np.ones_like(r)
    s = r / delta  # linear-interpolation start
    for _ in range(_NEWTON_ITER):
        s2, s3 = s * s, s * s * s
        f = (3 * s2 - 2 * s3) * delta + (s3 - 2 * s2 + s) * a0 + (s3 - s2) * a1 - r
        df = (6 * s - 6 * s2) * delta + (3 * s2 - 4 * s + 1) * a0 + (3 * s2 - 2 * s) * a1
        lo = np.where(f < 0, s, lo)
        hi = np.where(f >= 0, s, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            s_new = s - f / df
        bad = ~np.isfinite(s_new) | (s_new <= lo) | (s_new >= hi)
        s_new = np.where(bad, 0.5 * (lo + hi), s_new)
        done = np.abs(s_new - s) <= 1e-14  # s in [0, 1]: time error <= 1e-14 h
        s = s_new
        if done.all():
            break
    return t0 + s * h


def pulse_times(
    t: np.ndarray,
    angle: np.ndarray,
    pulses_per_rev: int,
    *,
    speed: np.ndarray | None = None,
    spacing_error_rad: float | np.ndarray | None = None,
    clock_hz: float | None = None,
    rng: np.random.Generator | int | None = None,
    jitter_s: float = 0.0,
) -> np.ndarray:
    """Times at which a toothed wheel on a shaft produces tachometer pulses.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s], strictly increasing (need not be uniform), n >= 2.
    angle : array_like, shape (n,)
        Shaft angle [rad] at `t`, non-decreasing (e.g. the integral of a simulated
        speed). Plateaus (standstill) are allowed.
    pulses_per_rev : int
        Pulses (teeth) per revolution, >= 1.
    speed : array_like, shape (n,), optional
        Shaft speed dθ/dt [rad/s] at `t`. If given, the angle between samples is the cubic
        Hermite interpolant with these slopes (exact for angle polynomials up to degree 3
        within a sample interval). Otherwise slopes are estimated by second-order finite
        differences (exact for constant acceleration) limited to keep it monotone.
    spacing_error_rad : float or array_like, optional
        Tooth position errors: an array of shape (pulses_per_rev,) [rad] (tooth ``k``
        at ``2 pi k / ppr + eps[k mod ppr]``), or a scalar std [rad] from which one
        pattern is drawn with `rng` (see `tooth_errors`). Each error must be smaller than
        half a pitch in magnitude. Default: no error.
    clock_hz : float, optional
        Counter clock frequency [Hz]. If given, each time is floored to a multiple of
        ``1 / clock_hz`` counted from t = 0 s (a counter latches the number of complete
        clock periods elapsed), so ``t_true - 1/clock_hz < t_reported <= t_true``.
    rng : numpy.random.Generator or int, optional
        Generator or seed; required when `spacing_error_rad` is a scalar std (drawn
        first) or `jitter_s` > 0.
    jitter_s : float, optional
        Pulse-time jitter [s rms] of the pick-up and its trigger: a normal draw added to
        each time before the clock quantisation, the result kept inside the record
        (``[t[0], t[-1]]``) and in order. Default 0.

    Returns
    -------
    ndarray, shape (n_pulses,)
        Pulse times [s], increasing, for every tooth angle in ``(angle[0], angle[-1]]``.
        With no spacing error and ``angle[0] = 0`` there are
        ``floor(angle[-1] ppr / 2 pi)`` pulses, the k-th (k = 1, 2, ...) when the angle
        reaches ``2 pi k / ppr``.

    Raises
    ------
    ValueError
        On NaN/inf, mismatched shapes, non-increasing `t`, decreasing `angle` (the
        message names the first offending sample), ``pulses_per_rev < 1``, spacing
        errors of the wrong shape or >= half a pitch, a scalar std or a jitter without
        `rng`, a negative jitter, or ``clock_hz <= 0``.
    """
    if isinstance(pulses_per_rev, bool) or not isinstance(pulses_per_rev, int | np.integer):
        raise ValueError(f"pulses_per_rev must be an integer >= 1, got {pulses_per_rev!r}")
    ppr = int(pulses_per_rev)
    if ppr < 1:
        raise ValueError(f"pulses_per_rev must be >= 1, got {ppr}")
    tt = _as_1d_finite(t, "t")
    th = _as_1d_finite(angle, "angle")
    if tt.size < 2 or th.shape != tt.shape:
        raise ValueError(
            f"t and angle must be 1-D with the same length >= 2, got {tt.shape} and {th.shape}"
        )
    dt = np.diff(tt)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0)) + 1
        raise ValueError(f"t must be strictly increasing (fails at sample {k})")
    dth = np.diff(th)
    if np.any(dth < 0):
        k = int(np.argmax(dth < 0)) + 1
        raise ValueError(
            f"angle must be non-decreasing (decreases at sample {k}: "
            f"{th[k - 1]!r} -> {th[k]!r}); the shaft must not turn backwards"
        )
    if speed is not None:
        om = _as_1d_finite(speed, "speed")
        if om.shape != tt.shape:
            raise ValueError(f"speed must have the shape of t {tt.shape}, got {om.shape}")
    if not np.isfinite(jitter_s) or jitter_s < 0:
        raise ValueError(f"jitter_s must be a finite time >= 0 s (rms), got {jitter_s}")
    if jitter_s > 0 and rng is None:
        raise ValueError("jitter_s > 0: pass rng (a numpy Generator or a seed) to draw it")
    gen = np.random.default_rng(rng) if isinstance(rng, int | np.integer) else rng
    if clock_hz is not None and (not np.isfinite(clock_hz) or clock_hz <= 0):
        raise ValueError(f"clock_hz must be a finite counter frequency > 0 Hz, got {clock_hz}")

    pitch = 2 * np.pi / ppr
    if spacing_error_rad is None:
        eps = np.zeros(ppr)
    elif np.ndim(spacing_error_rad) == 0:
        if rng is None:
            raise ValueError(
                "spacing_error_rad is a scalar std: pass rng (a numpy Generator or a seed) "
                "to draw the tooth pattern, or pass the pattern as an array"
            )
        eps = tooth_errors(ppr, float(spacing_error_rad), gen)
    else:
        eps = _as_1d_finite(spacing_error_rad, "spacing_error_rad")
        if eps.shape != (ppr,):
            raise ValueError(
                f"spacing_error_rad must have shape ({ppr},) = (pulses_per_rev,), "
                f"got {eps.shape}"
            )
    if np.any(np.abs(eps) >= pitch / 2):
        raise ValueError("spacing_error_rad must be smaller than half a tooth pitch (pi / ppr)")

    if speed is None:
        om = _hermite_slopes(tt, th)

    # Candidate teeth, then keep those strictly after the start and up to the end angle.
    emax = float(np.max(np.abs(eps)))
    k_lo = int(np.floor((th[0] - emax) / pitch)) - 1
    k_hi = int(np.ceil((th[-1] + emax) / pitch)) + 1
    k = np.arange(k_lo, k_hi + 1)
    target = k * pitch + eps[np.mod(k, ppr)]
    target = target[(target > th[0]) & (target <= th[-1])]
    if target.size == 0:
        return np.empty(0)

    # Segment i satisfies th[i] < target <= th[i+1] (plateaus are skipped automatically).
    i = np.searchsorted(th, target, side="left") - 1
    h = dt[i]
    times = _invert_hermite(tt[i], h, dth[i], om[i], om[i + 1], target - th[i])
    if jitter_s > 0:
        # jitter far below a pulse interval (the config checks it) rarely reorders; a
        # counter still reports increasing times
        times = np.sort(np.clip(times + jitter_s * gen.standard_normal(times.size),
                                tt[0], tt[-1]))
    if clock_hz is not None:
        times = np.floor(times * clock_hz) / clock_hz
    return times


def analog_channel(
    t: np.ndarray,
    pulse_times: np.ndarray,
    width_s: float,
    high: float = 5.0,
    low: float = 0.0,
    *,
    edge_s: float = 0.0,
) -> np.ndarray:
    """Sampled analog tachometer signal: a pulse of `width_s` starting at each pulse time.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s], non-decreasing.
    pulse_times : array_like, shape (n_pulses,)
        Rising-edge times [s], non-decreasing (e.g. from `pulse_times`).
    width_s : float
        Pulse width [s], > 0. Overlapping pulses merge.
    high, low : float
        Signal levels [V].
    edge_s : float
        Rise/fall time [s], >= 0. With 0 the signal is ``high`` on ``[p, p + width_s)``
        (first high sample is the first sample at or after the edge). With ``edge_s > 0``
        each edge is a linear ramp centred on the edge time, so the 50 % level is crossed
        exactly at ``p`` (rising) and ``p + width_s`` (falling): linear interpolation at
        mid level recovers the edge time to rounding if ``edge_s`` >= the sample interval.

    Returns
    -------
    ndarray, shape (n,)
        Signal samples [V].
    """
    tt = _as_1d_finite(t, "t")
    pt = _as_1d_finite(pulse_times, "pulse_times")
    if np.any(np.diff(pt) < 0):
        raise ValueError("pulse_times must be non-decreasing")
    if not np.isfinite(width_s) or width_s <= 0:
        raise ValueError(f"width_s must be a finite pulse width > 0 s, got {width_s}")
    if not np.isfinite(edge_s) or edge_s < 0:
        raise ValueError(f"edge_s must be a finite rise time >= 0 s, got {edge_s}")
    if edge_s >= width_s:
        raise ValueError("edge_s must be shorter than width_s")
    if pt.size == 0:
        return np.full(tt.shape, float(low))
    # Level of the most recent pulse that could still affect sample t (equal widths: the
    # latest-starting pulse dominates the union of overlapping pulses).
    j = np.searchsorted(pt, tt + 0.5 * edge_s, side="right") - 1
    tau = tt - pt[np.maximum(j, 0)]  # time since that pulse's nominal rising edge
    if edge_s > 0:
        rise = np.clip(tau / edge_s + 0.5, 0.0, 1.0)
        fall = np.clip((width_s - tau) / edge_s + 0.5, 0.0, 1.0)
        frac = np.minimum(rise, fall)
        # Falling ramp of the previous pulse may overlap the next rising ramp.
        jp = j - 1
        tau_p = tt - pt[np.maximum(jp, 0)]
        prev = np.clip((width_s - tau_p) / edge_s + 0.5, 0.0, 1.0)
        prev = np.where(jp >= 0, np.minimum(prev, np.clip(tau_p / edge_s + 0.5, 0, 1)), 0.0)
        frac = np.maximum(frac, prev)
    else:
        frac = ((tau >= 0) & (tau < width_s)).astype(float)
    frac = np.where(j >= 0, frac, 0.0)
    return low + (high - low) * frac
