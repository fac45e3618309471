"""Honesty checks on every step of the GP-SSM filter: divergence, the physics floor, the
lateral-velocity band.

Applied after the filter's step by both implementations
(:mod:`roadgrip.estimators.gpssm.stepping` and
:mod:`roadgrip.estimators.gpssm.reference`), on the estimate and the particle state:

Divergence
    The step is flagged ``diverged`` when the estimated lateral velocity leaves what any
    car not spinning out allows (``|vy| > max_sideslip_ratio vx``, 0.5 vx is about
    27 deg of body sideslip) or the learned frictions push against the slips of both
    axles (``reverse_slip``, ``reverse_mu``: no passive tire does), or when no particle
    explains the yaw rate
    (``|r_meas - r_est|`` above ``5 sqrt(sigma_r² + yaw_rate_std²)``), or, without a
    measured lateral velocity, when the yaw rate is unexplained *on average* over the last
    second (the mean of ``(r_meas - r_est)² / (sigma_r² + yaw_rate_std²)`` over a full
    ``FLOOR_WINDOW`` of recorded samples above ``_YAW_NIS_MAX`` = 10²: a filter locked on a
    wrong lateral state in a slalom meets the gyro at every zero crossing, which resets
    the ``diverge_time`` wait of the per-sample test), or the estimated
    slip angles contradict the measured lateral acceleration (both axles past
    ``slide_slip`` with one sign while the last second's mean ``a_y`` is below
    ``slide_mu g`` that way: a tire that slides carries force), or the weights have
    collapsed (effective sample size below 1.5) for ``diverge_time`` seconds in a row.
    A flagged step reports the prior band ``[0, peak_max]`` for both peaks, not
    observed, ``vy_std`` at least ``max(sigma_vy0, |vy|)``, and the particles' lateral
    velocity and yaw rate are re-initialised as at
    the start (``vy ~ N(0, sigma_vy0²)``, the yaw rate from the gyro); the learned
    statistics are kept. The output stays flagged for ``diverge_time`` after the
    re-initialisation while the state settles, and for ``relearn_time`` after it no peak
    is reported observed and the lower bands are the physics floor (the statistics still
    hold the curve learned on the wrong lateral state until forgetting renews them).
Physics floor
    ``floor`` is the largest ``|mean a_y| / g`` over a full trailing second of recorded
    samples up to the step: the friction the car demonstrably used. No upper bound is reported below it
    (the accelerometer as read), nor below the same of the accelerometer where the filter's
    ``a_y`` is another source (``ay_source='kinematic'``: on the DART recordings the
    hobby-grade accelerometer's second means run above the kinematic ``a_y``'s). Over the learned accelerometer gain
    (:attr:`GPSSMConfig.ay_gain_sigma`) it is the floor of the peak estimates: an observed
    peak more than ``floor_margin`` below it is reported as not observed (the learned
    curve contradicts the data), and no ``mu_*`` is reported below it.
Lower band of a peak not observed
    No higher than the largest ``|mu_now|`` the filter has estimated the axle to use on a
    step not flagged since the start or the last re-initialisation (:attr:`Guard.used`),
    or the floor over the gain if that is higher: the peak is known to be at least what
    the axle was seen to use. The learned curve's maximum over the visited slips may run
    above that between the data (on the random family's ``random:108`` snow slalom, a rear
    lower band of 0.33-0.345 against a true peak of 0.30 for 0.8 s, where the axle was
    estimated to use at most 0.29).
Lateral-velocity band
    ``vy_std`` includes ``slip_sigma |vx|`` in quadrature, the slip-angle error the curve
    band assumes too: without a measured lateral velocity the particle spread after
    resampling under-represents the error of ``vy``; with one (``vy_source='pose'``) every
    particle takes the measurement, which has its own error (small for motion capture, 0.1-0.16 m/s
    for the F1/10 localisation, :func:`roadgrip.io.presets.frictionmaps_options`).
    Without a measured lateral velocity it also includes ``slip_scale_sigma |vy - l_r r|``
    in quadrature: the rear slip velocity ``v_x tan(alpha_r)`` over a scale of the slip
    angles that ``a_y`` and the yaw rate do not identify (:class:`GPSSMConfig`).
Collapsed weights
    A step whose effective sample size is below 1.5 particles resamples copies of one
    particle, whose spread says nothing, and the copies stay nearly equal for some steps
    after (equal weights, so a fine effective sample size). Such a step, or one whose
    yaw-rate spread is below a hundredth of the gyro's noise, is flagged ``collapsed``
    and reports ``yaw_rate_std`` of at least the gyro's noise ``sigma_yaw_rate``: the
    yaw rate is then known as well as the gyro reads it, not better. (The curve and peak
    bands come from the surviving particle's own conjugate posterior and stay valid;
    collapse that lasts ``diverge_time`` is a divergence.)
"""

from __future__ import annotations

import math

import numba
import numpy as np

from roadgrip.constants import GRAVITY, Z95
from roadgrip.estimators.gpssm.inputs import Sample
from roadgrip.estimators.gpssm.model import State

__all__ = ["FLOOR_WINDOW", "Guard", "ay_noise", "guard_step", "step_sigma_ay"]

FLOOR_WINDOW = 1.0
"""Window [s] of the sustained lateral acceleration of the physics floor."""

_ESS_COLLAPSED = 1.5
_COPIES = 0.01
"""A yaw-rate spread below this fraction of the gyro's noise is copies of one particle."""
_YAW_SIGMAS = 5.0
_YAW_NIS_MAX = 100.0
"""Largest mean normalised yaw-rate innovation over the guard's window (a mean miss of
ten standard deviations): past it the particles do not explain the gyro over the last
second. Measured (mean over 1 s, ``docs/validation-honesty.md``): at most 2.3 on the
30-s sine-burst where the filter follows the car (4 of 5 filter seeds), 3.8 on a
multi-body snow slalom, 16 on a multi-body dry-gravel-dry, 27 on a 100-particle run of
the snow slalom, 49 on the race car; 570 on the sine-burst's fifth seed, locked from
its first burst on a wrong lateral velocity and accelerometer gain, and 890 on a
dry-gravel-dry drive whose lateral velocity drifted."""


class Guard:
    """Per-run bookkeeping of :func:`guard_step` (mutable, copied by ``copy_state``).

    Attributes
    ----------
    times, ay : list of float
        The last ``FLOOR_WINDOW`` seconds of samples: time [s] and measured ``a_y``
        [m/s²].
    accel : list of float
        The accelerometer's ``a_y`` [m/s²] at the same times where the filter's ``a_y`` is
        another source (:attr:`Sample.ay_accel`; NaN otherwise).
    nis : list of float
        The normalised squared yaw-rate innovation [-] at the same times (0 before a
        re-initialisation).
    floor_raw : float
        Running maximum of ``|mean a_y| / g`` over full windows, as read.
    floor_accel : float
        The same of the accelerometer's ``a_y`` (0 while the filter's is the accelerometer's).
    bad_since : float
        Time [s] since which the yaw-rate or weight check has failed (NaN: passing).
    flagged_until : float
        Time [s] until which the output stays flagged after a re-initialisation.
    resets : int
        Re-initialisations so far.
    used : list of float
        Per axle (front, rear), the largest ``|mu_now|`` [-] of the steps not flagged since
        the start or the last re-initialisation: the friction the filter has seen the axle use.
    """

    __slots__ = ("accel", "ay", "bad_since", "flagged_until", "floor_accel", "floor_raw", "nis", "resets",
                 "times", "used")

    def __init__(self) -> None:
        self.times: list[float] = []
        self.ay: list[float] = []
        self.accel: list[float] = []
        self.nis: list[float] = []
        self.floor_raw = 0.0
        self.floor_accel = 0.0
        self.bad_since = math.nan
        self.flagged_until = -math.inf
        self.resets = 0
        self.used = [0.0, 0.0]

    def copy(self) -> Guard:
        g = Guard()
        g.times, g.ay, g.accel, g.nis = list(self.times), list(self.ay), list(self.accel), list(self.nis)
        g.floor_raw, g.bad_since, g.floor_accel = self.floor_raw, self.bad_since, self.floor_accel
        g.flagged_until, g.resets = self.flagged_until, self.resets
        g.used = list(self.used)
        return g

    def add(self, t: float, ay: float, dt_hint: float, accel: float = math.nan, nis: float = 0.0) -> bool:
        """Add a sample and update the floors (a window counts once it spans
        ``FLOOR_WINDOW`` less one and a half sample intervals; the accelerometer's once
        its values in the window are all numbers). Returns whether the window is full."""
        self.times.append(t)
        self.ay.append(ay)
        self.accel.append(accel)
        self.nis.append(nis)
        while self.times and self.times[0] <= t - FLOOR_WINDOW + 1e-9:
            self.times.pop(0)
            self.ay.pop(0)
            self.accel.pop(0)
            self.nis.pop(0)
        full = bool(self.times) and t - self.times[0] >= FLOOR_WINDOW - 1.5 * dt_hint
        if full:
            self.floor_raw = max(self.floor_raw, abs(sum(self.ay) / len(self.ay)) / GRAVITY)
            s = sum(self.accel)
            if not math.isnan(accel) and not math.isnan(s):
                self.floor_accel = max(self.floor_accel, abs(s / len(self.accel)) / GRAVITY)
        return full


def ay_noise(ay) -> float:
    """Noise std [m/s²] of evenly sampled values from their second differences.

    For white noise of std ``sigma`` on a signal that changes slowly over three samples,
    ``y[k+1] - 2 y[k] + y[k-1]`` has variance ``6 sigma²``: the estimate is
    ``sqrt(mean(d²) / 6)`` over the window (0 with fewer than three values). The signal's
    own curvature adds to it (``(2 pi f)² A dt²`` for a sine), so it bounds the noise from
    above.

    >>> round(ay_noise([0.0, 1.0, 0.0, 1.0, 0.0]), 4)  # d = -2, 2, -2: sqrt(4 / 6)
    0.8165
    """
    return float(second_difference_noise(np.asarray(ay, dtype=np.float64)))


@numba.njit(cache=True)
def second_difference_noise(ay):  # pragma: no cover - compiled
    """:func:`ay_noise` of an array, shape (n,) (compiled: the filter's step calls it on
    its window of recorded samples)."""
    n = ay.shape[0]
    if n < 3:
        return 0.0
    s = 0.0
    for j in range(1, n - 1):
        d = ay[j + 1] - 2.0 * ay[j] + ay[j - 1]
        s += d * d
    return math.sqrt(s / (6.0 * (n - 2)))


def step_sigma_ay(ctx, guard: Guard) -> float:
    """The lateral-acceleration noise [m/s²] of a step's likelihood: ``ctx.sigma_ay``, or
    with ``GPSSMConfig.ay_noise = 'running'`` the larger of it and the accelerometer's
    noise measured over the last ``FLOOR_WINDOW`` of recorded samples (:func:`ay_noise`,
    times ``sqrt(substeps)`` as ``ctx.sigma_ay``)."""
    if ctx.noise_scale == 0.0:
        return ctx.sigma_ay
    return max(ctx.sigma_ay, ctx.noise_scale * ay_noise(guard.ay))


def guard_step(ctx, state, est, sample: Sample, dt: float):
    """The checks of the module docstring after one step.

    Parameters
    ----------
    ctx : Context
    state : GPSSMState
        The state after the step; its particles are re-initialised in place on
        divergence (random numbers from ``state.rng``).
    est : GPSSMEstimate
    sample : Sample
    dt : float
        The step's interval [s] (0 at the first sample).

    Returns
    -------
    GPSSMEstimate
        With ``diverged``, ``floor``, ``collapsed``, the widened ``vy_std`` and
        ``yaw_rate_std`` and the bands.
    """
    config = ctx.config
    g = state.guard
    t = float(sample.t)
    yaw_var = ctx.sigma_yaw_rate**2 + est.yaw_rate_std**2
    nis = (sample.yaw_rate - est.yaw_rate) ** 2 / yaw_var
    full = False
    if sample.recorded:
        # recorded samples only: the floor of the data, not of the interpolated sub-steps
        full = g.add(t, float(sample.ay), t - g.times[-1] if g.times else (dt if dt > 0 else 0.04),
                     float(sample.ay_accel), float(nis))
    # the floor over the accelerometer gain as learned now (a constant of the car)
    floor_gain = g.floor_raw / max(est.ay_gain, 1e-6)
    vx = float(sample.vx)
    moving = vx >= config.min_speed
    measured_vy = not math.isnan(sample.vy)
    vy_std = math.sqrt(est.vy_std**2 + (config.slip_sigma * vx) ** 2)
    if not measured_vy:
        # the slip angles' scale is not identified: the rear axle's slip velocity
        vy_std = math.hypot(vy_std, config.slip_scale_sigma * (est.vy - ctx.veh.lr * est.yaw_rate))
    if not moving:
        # near standstill the filter holds vy at 0: its band is what a measurement says
        # against that, or a sideslip of max_sideslip_ratio at min_speed
        gap = abs(sample.vy - est.vy) if measured_vy else config.max_sideslip_ratio * config.min_speed
        vy_std = max(vy_std, gap / Z95)
    # divergence
    yaw_gap = abs(sample.yaw_rate - est.yaw_rate) > _YAW_SIGMAS * math.hypot(ctx.sigma_yaw_rate, est.yaw_rate_std)
    n_rev = _reversed(config, est)
    unexplained = full and _mean(g.nis) > _YAW_NIS_MAX
    runaway = moving and not measured_vy and (abs(est.vy) > config.max_sideslip_ratio * vx
                                              or n_rev == 2 or unexplained)
    slide_gap = not measured_vy and _slide_gap(config, est.alpha_f, est.alpha_r,
                                               _mean(g.ay) / max(est.ay_gain, 1e-6))
    if moving and (yaw_gap or slide_gap or est.ess < _ESS_COLLAPSED):
        if math.isnan(g.bad_since):
            g.bad_since = t
    else:
        g.bad_since = math.nan
    lost = not math.isnan(g.bad_since) and t - g.bad_since >= config.diverge_time
    if runaway or lost:
        _reinitialise(ctx, state, sample)
        g.nis = [0.0] * len(g.nis)  # the innovations of the state left behind
        g.resets += 1
        g.bad_since = math.nan
        g.flagged_until = t + config.diverge_time
        g.used = [0.0, 0.0]  # what the wrong lateral state said the axles used
    diverged = bool(runaway or lost or t < g.flagged_until)
    if diverged and not measured_vy:
        # the lateral state is unknown: its band as wide as the start's, or the estimate
        vy_std = max(vy_std, config.sigma_vy0, abs(est.vy))
    yaw_std = est.yaw_rate_std
    collapsed = bool(est.ess < _ESS_COLLAPSED or yaw_std < _COPIES * ctx.sigma_yaw_rate)
    if collapsed:
        yaw_std = max(yaw_std, ctx.sigma_yaw_rate)
    rep = {"vy_std": vy_std, "yaw_rate_std": yaw_std, "diverged": diverged, "floor": g.floor_raw,
           "collapsed": collapsed}
    for i, axle in enumerate(("front", "rear")):
        obs = getattr(est, f"peak_observed_{axle}")
        mu = getattr(est, f"mu_{axle}")
        lo, hi = getattr(est, f"mu_{axle}_lower"), getattr(est, f"mu_{axle}_upper")
        if not diverged:
            g.used[i] = max(g.used[i], abs(getattr(est, f"mu_now_{axle}")))
        if obs and mu < floor_gain - config.floor_margin:
            obs, hi = False, config.peak_max  # an observed peak below what the car used
        if not obs:
            # a lower bound on the peak no higher than the axle has been estimated to use
            # (or the floor): the learned curve's maximum over the visited slips may run above it
            lo = min(lo, max(g.used[i], floor_gain))
        # the car demonstrably used the floor: no peak estimate below it (a small shortfall
        # of an observed peak is within the floor's noise)
        mu = max(mu, floor_gain)
        if t < g.flagged_until - config.diverge_time + config.relearn_time:
            # relearning after a re-initialisation: the curve still holds what was
            # learned on the wrong lateral state
            obs, lo, hi = False, min(lo, floor_gain), config.peak_max
        if diverged:
            obs, lo, hi = False, 0.0, config.peak_max
        rep[f"mu_{axle}"] = float(mu)
        rep[f"peak_observed_{axle}"] = bool(obs)
        rep[f"mu_{axle}_lower"] = float(min(lo, mu))
        # the upper band's floor: what the filter's a_y or the accelerometer shows the car used
        rep[f"mu_{axle}_upper"] = float(max(hi, g.floor_raw, g.floor_accel, mu))
    return est._replace(**rep)


def _mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else 0.0


def _reversed(config, est) -> int:
    """How many axles are past ``reverse_slip`` with a learned friction that pushes against
    the slip by more than ``reverse_mu`` (no passive tire does that)."""
    n = 0
    for alpha, mu in ((est.alpha_f, est.mu_now_front), (est.alpha_r, est.mu_now_rear)):
        if abs(alpha) > config.reverse_slip and mu * math.copysign(1.0, alpha) < -config.reverse_mu:
            n += 1
    return n


def _slide_gap(config, alpha_f: float, alpha_r: float, ay_mean: float) -> bool:
    """Both slip angles past ``slide_slip`` with one sign, and the mean lateral
    acceleration [m/s²] below ``slide_mu g`` that way: slip the car's force contradicts."""
    if min(abs(alpha_f), abs(alpha_r)) <= config.slide_slip or alpha_f * alpha_r <= 0.0:
        return False
    return ay_mean * math.copysign(1.0, alpha_f) < config.slide_mu * GRAVITY


def _reinitialise(ctx, state, sample: Sample) -> None:
    """The particles' lateral velocity and yaw rate as at the start, in place."""
    N = state.x.shape[0]
    rng = state.rng
    config = ctx.config
    vy = config.sigma_vy0 * rng.standard_normal(N)
    if config.max_sideslip is not None:
        lim = math.tan(config.max_sideslip) * max(float(sample.vx), 0.0)
        vy = np.clip(vy, -lim, lim)
    state.x[:, State.VY] = vy
    state.x[:, State.YAW_RATE] = sample.yaw_rate + ctx.sigma_yaw_rate * rng.standard_normal(N)
    state.logw[:] = -math.log(N)
