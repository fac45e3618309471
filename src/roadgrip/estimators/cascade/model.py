r"""Three-stage Kalman cascade for axle friction (paper 003, Amine et al.; after Hu et al.).

=========  ===============================  ==================================================
stage      filter, equations                 estimates
=========  ===============================  ==================================================
1          EKF, eq. 1-5                      ``vx, vy`` from ``ax, ay``, yaw rate, measured speed
2          UKF1, eq. 6-10                    ``vx, r, vy, Fxf, Fyf, Fyr`` (axle forces)
3          UKF2, eq. 11-12                   ``mu_f, mu_r`` through the brush model
=========  ===============================  ==================================================

Models (SI units, ISO 8855 axes; ``T`` is the sample interval)
---------------------------------------------------------------
*Stage 1* (eq. 2-4, kinematics with the signs of ISO axes: ``ay = vy' + vx r``)::

    [vx, vy]_k = Rot(-r T) [vx, vy] + T Rot(-r T / 2) [ax, ay],   z = vx_measured

with ``ax, ay, r`` the means of the samples at both ends of the step.
This is the paper's ``vx_k = vx + T (ax + vy r)``, ``vy_k = vy + T (ay - vx r)``
with the rotation of the velocity vector over the step made exact (see
:func:`_rotate_integrate`) and the inputs integrated by the trapezoid rule:
at the yaw rates of a small car the Euler form, with the inputs of one end of
the step, biases ``vy`` by 1-2 cm/s, i.e. the slip angles by 5 mrad. The
Jacobian of the velocity part is ``F = Rot(-r T)``.

The state also holds the accelerometer biases ``bx, by`` (random walks,
subtracted from ``ax, ay`` here and in stage 2), learnt at standstill by a
zero-velocity update (the accelerometers then read their biases) and while
driving through the speed measurement. A sensor 2 degrees off level reads
0.34 m/s² of gravity, which stage 1 would otherwise take for ``vy r`` and turn
into a lateral-velocity error of ``0.34 / r`` m/s; the real F1/10 runs show a
mean ``ax`` of about -0.6 m/s² at standstill. The bias states are on when the
drive contains a standstill of at least 1 s (``accel_bias_std=None``), which
makes them observable, and otherwise off unless configured.

On straights (yaw rate near zero) ``vy`` is not observable from ``vx`` and its
integral drifts with the accelerometer noise. Below a lateral acceleration of
``ay_straight`` stage 1 therefore adds a pseudo-measurement from the linear
tire, ``vy = lr r - vx alpha_r`` with ``alpha_r = m ay lf / (l C_r)``, standard
deviation ``|vx| (slip_bias_std + |alpha_r|) + 0.01 m/s``. It is off in
cornering, where the tires may be nonlinear and the friction information lies.

*Pose velocity.* When the drive carries a body velocity differentiated from a
localisation pose (columns ``vx_pose, vy_pose``, e.g. the particle-filter pose
of the F1/10 runs, :func:`roadgrip.io.frictionmaps.pose_body_velocity`), stage 1
fuses it as a direct measurement of ``[vx, vy]`` with standard deviation
``pose_velocity_std``; NaN marks samples without one (near localisation jumps).
The pose error is correlated over the differentiation window
(``pose_velocity_corr_time``), so each sample's variance is inflated by
``corr_time / T``: a window counts as one independent measurement. This bounds
the drift of the integrated ``vy`` in cornering, where the straight-driving
pseudo-measurement is off. On the F1/10 run DS5 the root-mean-square
difference between the stage-1 ``vy`` and the pose ``vy`` is 0.37 m/s with the
noise estimated from the resampled signals, 0.24 m/s with the native noise
(see *Sensor noise*) and 0.18 m/s with the pose velocity as well (the pose's
own scatter is about 0.1 m/s); on DS4 1.01, 0.72 and 0.42 m/s.

The inputs ``u = [ax, ay, r]`` are measured, so the state noise follows from the
sensor noise: ``Q1 = T² (diag(sa², sa²) + sr² g gᵀ)`` with ``g = [vy, -vx]``
(first-order propagation of accelerometer noise ``sa`` and gyro noise ``sr``;
``sa²`` includes the accelerometer model error ``accel_model_std²``, which stands
for bias, road grade and mounting offset), ``R1 = sv²`` the speed-sensor noise.
The measured speed (eq. 5) is the mean wheel speed of the undriven axle, a
measured ``vx`` column (preferred on four-wheel-driven cars, whose wheels all
slip under drive; else all four wheels), or the motor speed through the gear
ratio ``rpm 2 pi R / (60 i)`` (:func:`measured_speed`). Steered front wheels
are modelled as turning at ``vx cos d + (vy + lf r) sin d``.

*Stage 2* (eq. 9-10, with the paper's sign typo in ``h5`` corrected)::

    vx_k = vx + T (r vy + (Fxf cos d - Fyf sin d) / m)          (rotation exact, as stage 1)
    r_k  = r  + T (lf (Fxf sin d + Fyf cos d) - lr Fyr) / Iz
    vy_k = vy + T (-r vx + (Fxf sin d + Fyf cos d + Fyr) / m)
    F_k  = F  (random walk)
    z    = [vx_EKF, r_gyro, vy_EKF, ax, ay]
    h    = [vx, r, vy, (Fxf cos d - Fyf sin d) / m, (Fxf sin d + Fyf cos d + Fyr) / m]

The model has one longitudinal force, applied at the front wheels as in the
paper: on a four-wheel or rear-wheel driven car ``Fxf`` is the total
longitudinal force (the split between axles is not observable from the
accelerations). Noise: the forces are random walks driven by a white force
rate of standard deviation ``m j`` (``j = jerk_std`` [m/s³]), so
``Q_F = (m j T)²`` per step; the velocities take the accelerometer model error,
``(T accel_model_std)²``, and the yaw rate that error across the wheelbase,
``(T accel_model_std / l)²``. ``R2`` is not tuned: its velocity block is the
stage-1 posterior covariance of the same step (time-varying), its yaw-rate
entry the gyro noise and its acceleration entries the accelerometer noise plus
model error. No force scaling is applied anywhere (the paper's factor of 100
compensated a unit inconsistency that does not arise here).

*Stage 3* (eq. 11-12)::

    mu_k = mu_{k-1} + w,  w ~ N(0, q_mu² T I)       (random walk, q_mu = mu_rate_std)
    z    = [Fyf, Fyr] (stage-2 posterior means)
    h_i  = Fz_i brush(alpha_i, mu_i, k_i)            (roadgrip.tire.brush_force)

with slip angles ``alpha_f = d - atan((vy + lf r) / vx)``,
``alpha_r = -atan((vy - lr r) / vx)`` (:mod:`roadgrip.vehicle.slip`
convention, so positive slip gives positive force), normal loads with
longitudinal load transfer (:meth:`VehicleParams.axle_loads`) and normalised
cornering stiffness ``k_i = C_i / Fz_i,static``. ``R3`` is diagonal with
``var(F_i)`` from the stage-2 covariance, plus ``(dF_i/dalpha_i)² var(alpha_i)``
(slip-angle uncertainty from the stage-2 covariance of ``vx, r, vy`` and the
steering noise, with the brush slope at the current estimate), plus a brush
model error ``(model_error * Fz_i)²``.

Information, excitation and variance growth
-------------------------------------------
In the linear range of the tire the force does not depend on ``mu``: the
update then carries no information and the random walk lets the variance grow,
up to the prior variance (a cap: the estimate never claims less than it knew
before any data). For each axle the update's information is the precision gain
``Lambda = 1/P_post - 1/P_prior``; a sample is *excited* for that axle when
``Lambda / T >= 1 / excitation_std²``, i.e. when one second of such samples
would determine ``mu`` to ``excitation_std`` (a threshold independent of the
sample rate), and when a slip-angle bias of ``slip_bias_std`` (or
``vy_bias_std / |vx|``, whichever is larger) would move the
observation by at most ``max_slip_bias_effect``: near the linear range the
force depends on ``mu`` only through its curvature, and a slip-angle bias (which
does not average out like noise) would be read as a friction change. The equivalent single-sample observation
``mu_obs = (m_post / P_post - m_prior / P_prior) / Lambda`` with variance
``1 / Lambda`` is reported (``mu_front_obs``, ``mu_front_obs_std``, ...), with
the systematic part ``mu_front_obs_sys``: the shift a slip-angle bias of
``slip_bias_std`` would cause, which does not shrink by averaging. This is
what :mod:`roadgrip.mapping` fuses, so that a map cell collects the likelihood
of the data taken in it rather than a filter state that remembers earlier cells.
The slip-angle bias assumed by this test is the larger of ``slip_bias_std``
and ``vy_bias_std / |vx|``. The data are also checked: at moderate lateral
acceleration (``ay_straight`` to twice that) the rear tire is close to linear,
so ``alpha_r - Fyr / C_r`` measures the slip-angle error; when its
root-mean-square over the last 5 s (exponential window) exceeds the assumed
bias, the test is repeated with the exact brush inversion at that larger
error (:func:`_slip_bias_effect`), which also catches a bias that would move
the tire between adhesion and sliding. The front axle's residual
``alpha_f - Fyf / C_f`` is tracked the same way.

The last test concerns the slip angle's *random* error: the exact inversion is
repeated at ``alpha ± z sqrt(var(alpha) + e²)`` (``z = slip_noise_z``,
``var(alpha)`` from the stage-2 covariance, ``e`` the axle's consistency
residual above) and must move by at most ``max_slip_bias_effect``. Without
it, a sample whose slip angle is overestimated lands on the sliding branch of
the brush model, where the local slope says the force no longer depends on the
slip, and reports ``mu = |F| / Fz``: the grip *used*, not the peak. On the
F1/10 runs 99 % of the excited samples were of that kind (cascade rear slip
0.2-0.55 rad where the pose gives 0.02-0.08 rad), and the maps followed how
hard each run was driven. A tire that, within its slip uncertainty, may as
well be in its linear range gives only the lower bound ``|F| / Fz``, which no
Gaussian observation expresses, so such samples are not excited. On logs whose slip angles are much
worse than assumed, few samples count as excited and the map keeps its prior.

A sample that fails the test for an axle leaves that axle's estimate where it
was (the update is discarded), so weak and possibly biased information from
the linear range does not move the friction estimate; its variance keeps
growing by the random walk.

Below ``v_min`` the slip angles are not defined well enough and stage 3 makes
no update. An update whose mean leaves the physical range ``mu_bounds`` is
projected back onto it and does not count as excited (the data then say only
that ``mu`` lies at or beyond the bound, which no Gaussian observation states).

Sensor noise
------------
Unless given in :class:`CascadeConfig`, the noise standard deviations of the
accelerometers, gyro and speed signal are taken from the reader
(``meta.extra['sensor_noise']``, measured on the native streams before
resampling) or else estimated from the drive itself by
:func:`noise_from_drive` (robust scale of second differences, which removes a
smooth signal and leaves white noise with variance ``6 s²``). On a signal
upsampled by linear interpolation the second differences vanish between
native samples, so the estimate from the drive is far too small: on the F1/10
runs (IMU at 18-30 Hz resampled to 50 Hz) 0.05 m/s² and 0.003 rad/s instead of
about 1 m/s² and 0.04-0.15 rad/s, which made the filters overconfident (mean
stage-2 NIS 126 for 5 degrees of freedom on DS5; 2.8 with the native noise).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields
from enum import IntEnum
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numba import njit
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive, DriveValidationError
from roadgrip.estimators.base import EstimateRequest, EstimateResult, conform, timed
from roadgrip.inference.kalman import (
    cholesky_lower,
    joseph_update,
    merwe_weights,
    psd_sqrt,
    sigma_points,
    ukf_correct,
    unscented_transform,
)
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "Cascade",
    "CascadeConfig",
    "CascadeEstimate",
    "CascadeSample",
    "CascadeState",
    "ForceMeasurement",
    "ForceState",
    "FrictionState",
    "VelocityState",
    "brush_mu_inverse",
    "force_measurement",
    "force_transition",
    "friction_measurement",
    "init",
    "measured_speed",
    "noise_from_drive",
    "run",
    "run_cli",
    "step",
]

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal."""


# -- state layouts -------------------------------------------------------------------


class VelocityState:
    """Stage-1 EKF state: eq. 4 plus the accelerometer biases."""

    VX = 0
    VY = 1
    BIAS_AX = 2
    BIAS_AY = 3
    SIZE = 4


class ForceState:
    """Stage-2 UKF1 state (eq. 6)."""

    VX = 0
    YAW_RATE = 1
    VY = 2
    FXF = 3
    FYF = 4
    FYR = 5
    SIZE = 6


class ForceMeasurement:
    """Stage-2 UKF1 measurement (eq. 6)."""

    VX = 0
    YAW_RATE = 1
    VY = 2
    AX = 3
    AY = 4
    SIZE = 5


class FrictionState:
    """Stage-3 UKF2 state (eq. 11)."""

    MU_F = 0
    MU_R = 1
    SIZE = 2


class _P(IntEnum):
    """Layout of the flat parameter vector of the compiled step."""

    MASS = 0
    IZ = 1
    LF = 2
    LR = 3
    H = 4
    KF = 5
    KR = 6
    VAR_ACC = 7
    VAR_GYRO = 8
    VAR_SPEED = 9
    VAR_STEER = 10
    VAR_ACC_MODEL = 11
    Q_FORCE = 12  # force-rate variance (m j)² [N²/s²]
    Q_YAW = 13  # yaw-acceleration variance [rad²/s⁴]
    Q_MU = 14  # mu variance per second
    MU_VAR0 = 15
    MU_MIN = 16
    MU_MAX = 17
    MODEL_ERR = 18
    EXC_PREC = 19
    V_MIN = 20
    V_EPS = 21
    FRONT_SHARE = 22
    SLIP_BIAS = 23
    MAX_BIAS = 24
    CR = 25
    AY_STRAIGHT = 26
    Q_BIAS = 27
    STEER_BIAS = 28
    VY_BIAS = 29
    CONSIST_TAU = 30
    VAR_POSE = 31  # pose-velocity variance per sample [m²/s²] times the sample interval [s]
    SLIP_Z = 32
    STEER_TAU = 33
    SIZE = 34


class _O(IntEnum):
    """Layout of one output row of the compiled step."""

    VX = 0
    YAW_RATE = 1
    VY = 2
    FXF = 3
    FYF = 4
    FYR = 5
    ALPHA_F = 6
    ALPHA_R = 7
    FZF = 8
    FZR = 9
    MU_F = 10
    MU_R = 11
    VAR_F = 12
    VAR_R = 13
    EXC_F = 14
    EXC_R = 15
    OBS_F = 16
    OBS_R = 17
    OBS_VAR_F = 18
    OBS_VAR_R = 19
    NIS2 = 20
    REPAIRS = 21
    VX_EKF = 22
    VY_EKF = 23
    PD_OK = 24
    FYF_VAR = 25
    FYR_VAR = 26
    ALPHA_F_VAR = 27
    ALPHA_R_VAR = 28
    R3_F = 29
    R3_R = 30
    SYS_F = 31
    SYS_R = 32
    SIZE = 33


# -- configuration -------------------------------------------------------------------


@dataclass(frozen=True)
class CascadeConfig:
    """Noise model and options of the cascade (SI units).

    Attributes
    ----------
    accel_std, gyro_std, speed_std : float or None
        White-noise standard deviations of the accelerometers [m/s²], gyro
        [rad/s] and speed signal [m/s]; ``None`` estimates them from the drive
        (:func:`noise_from_drive`).
    steer_std : float
        Steering-angle noise [rad].
    steer_bias_std : float
        Systematic steering-angle error [rad], added to ``slip_bias_std`` for the
        front axle (e.g. 0.05 when ``steer`` is a command rather than a measured
        road-wheel angle, as in the F1/10 data of paper 003).
    steer_response_time : float or None
        Time constant [s] of the steering actuator when ``steer`` is a command
        rather than a measured road-wheel angle: the command change not yet
        followed, ``|steer - lowpass(steer)|`` (first-order low-pass with this
        time constant), is added to the steering-angle standard deviation of
        the front slip angle. ``None``: 0.1 s when the drive says its steering
        is a command (``meta.extra['steer_is_command']``, set by the
        frictionmaps reader), else 0 (a measured angle).
    accel_model_std : float
        Accelerometer model error [m/s²] (bias, grade, mounting offset), added to
        the accelerometer noise in stages 1 and 2.
    accel_bias_std : float or None
        Initial standard deviation of the accelerometer biases [m/s²] (a tilt of
        the sensor by 2 degrees gives 0.34 m/s²); 0 switches the bias states off.
        ``None``: 0.3 when the drive contains a standstill of at least 1 s, which
        makes the biases observable (zero-velocity update), else off.
    accel_bias_rate_std : float
        Random-walk intensity of the biases [m/s²/sqrt(s)] (when they are on).
    jerk_std : float
        Force random-walk intensity expressed as a jerk [m/s³]: ``Q_F = (m j T)²``.
    mu_rate_std : float
        Friction random-walk intensity [1/sqrt(s)] (eq. 11).
    mu_prior : float
        Initial friction estimate [-].
    mu_prior_std : float
        Initial standard deviation [-], also the cap of the variance growth.
    mu_bounds : tuple of float
        Physical range of ``mu`` [-]; sigma points are clipped to it inside the
        brush model and the mean is projected onto it.
    model_error : float
        Brush-model error as a fraction of the normal load [-].
    excitation_std : float
        A sample is excited for an axle when one second of samples carrying the
        same information would determine ``mu`` to this standard deviation [-]
        (the single-sample observation variance times the sample rate).
    slip_bias_std : float
        Size of a slip-angle bias [rad] (velocity-estimation and model error) that,
        unlike noise, does not average out over samples.
    vy_bias_std : float
        Size of a lateral-velocity bias [m/s]; the slip-angle bias used is the
        larger of ``slip_bias_std`` and ``vy_bias_std / |vx|`` (slow driving
        turns a small velocity error into a large slip-angle error).
    max_slip_bias_effect : float
        A sample counts as excited only if a slip-angle error of ``slip_bias_std``
        would move its ``mu`` observation by at most this much [-]: close to the
        linear range of the tire, ``mu`` follows from the small curvature of the
        force and any slip bias maps into a large friction error.
    slip_noise_z : float
        A sample counts as excited only if the brush inversion also moves by at
        most ``max_slip_bias_effect`` when the slip angle moves by ``slip_noise_z``
        of its own standard deviations (stage-2 covariance); 0 disables this test.
    ay_straight : float
        Below this lateral acceleration [m/s²] stage 1 adds the straight-driving
        pseudo-measurement of ``vy`` (module docstring); 0 disables it.
    pose_velocity_std : float
        Standard deviation [m/s] of the pose-derived body velocity
        (``vx_pose, vy_pose`` columns, e.g. from the localisation of the
        frictionmaps runs); 0 ignores those columns. See *Pose velocity*.
    pose_velocity_corr_time : float
        Correlation time [s] of the pose-velocity error (the smoothing window of
        the differentiation): each sample's variance is inflated by
        ``corr_time / T`` so that one window carries the information of one
        independent measurement.
    v_min : float
        No friction update below this speed [m/s].
    v_eps : float
        Slip-angle speed regularisation [m/s] (:mod:`roadgrip.vehicle.slip`).
    speed_source : str
        ``'auto'``, ``'wheels'``, ``'vx'``, ``'vx_motor'`` or ``'motor_rpm'``
        (:func:`measured_speed`).
    alpha, beta, kappa : float
        Unscented-transform parameters (:func:`roadgrip.inference.kalman.merwe_weights`).
    """

    accel_std: float | None = None
    gyro_std: float | None = None
    speed_std: float | None = None
    steer_std: float = 0.005
    steer_bias_std: float = 0.0
    steer_response_time: float | None = None
    accel_model_std: float = 0.1
    accel_bias_std: float | None = None
    accel_bias_rate_std: float = 0.002
    jerk_std: float = 30.0
    mu_rate_std: float = 0.2
    mu_prior: float = 0.7
    mu_prior_std: float = 0.4
    mu_bounds: tuple[float, float] = (0.05, 2.0)
    model_error: float = 0.02
    excitation_std: float = 0.5
    slip_bias_std: float = 0.01
    vy_bias_std: float = 0.03
    max_slip_bias_effect: float = 0.1
    slip_noise_z: float = 2.0
    ay_straight: float = 1.0
    pose_velocity_std: float = 0.1
    pose_velocity_corr_time: float = 0.3
    v_min: float = 1.0
    v_eps: float = 0.1
    speed_source: str = "auto"
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("speed_source", "mu_bounds") or v is None:
                continue
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"cascade option {f.name!r} must be finite and >= 0, got {v!r}")
        for name in ("jerk_std", "mu_rate_std", "mu_prior_std", "excitation_std", "alpha"):
            if getattr(self, name) <= 0:
                raise ValueError(f"cascade option {name!r} must be positive")
        lo, hi = self.mu_bounds
        if not 0 < lo < self.mu_prior < hi:
            raise ValueError(f"need 0 < mu_bounds[0] < mu_prior < mu_bounds[1], got {self.mu_bounds}, {self.mu_prior}")
        if self.speed_source not in _SPEED_SOURCES:
            raise ValueError(f"speed_source must be one of {_SPEED_SOURCES}, got {self.speed_source!r}")

    @classmethod
    def from_options(cls, options: dict[str, Any]) -> CascadeConfig:
        """Build from a mapping; unknown keys are an error naming them."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise ValueError(f"unknown cascade option(s) {unknown}; known: {sorted(known)}")
        return cls(**options)


_SPEED_SOURCES = ("auto", "wheels", "vx", "vx_motor", "motor_rpm")


# -- immutable state, sample, estimate ------------------------------------------------


class CascadeState(NamedTuple):
    """Posterior of the three stages after a sample.

    Attributes
    ----------
    t : float
        Time of the last sample [s] (NaN before the first).
    velocity_mean, velocity_cov : ndarray, (4,), (4, 4)
        Stage 1 (:class:`VelocityState`).
    force_mean, force_cov : ndarray, (6,), (6, 6)
        Stage 2 (:class:`ForceState`).
    friction_mean, friction_cov : ndarray, (2,), (2, 2)
        Stage 3 (:class:`FrictionState`).
    inputs : ndarray, (6,)
        ``ax, ay, yaw_rate`` of the last sample (stage 1 integrates the mean of
        the inputs at both ends of a step), the running mean squares of the
        rear and front slip-angle consistency residuals [rad²] (module
        docstring) and the low-passed steering angle [rad] (NaN before the
        first sample; ``steer_response_time``).
    """

    t: float
    velocity_mean: NDArray[np.float64]
    velocity_cov: NDArray[np.float64]
    force_mean: NDArray[np.float64]
    force_cov: NDArray[np.float64]
    friction_mean: NDArray[np.float64]
    friction_cov: NDArray[np.float64]
    inputs: NDArray[np.float64]


class CascadeSample(NamedTuple):
    """One sample of the inputs (SI): time, accelerations, yaw rate, steering, measured speed.

    ``vx_pose, vy_pose`` [m/s] are the optional body velocity derived from a
    localisation pose (NaN: none at this sample; module docstring, *Pose velocity*).
    """

    t: float
    ax: float
    ay: float
    yaw_rate: float
    steer: float
    speed: float
    vx_pose: float = float("nan")
    vy_pose: float = float("nan")


class CascadeEstimate(NamedTuple):
    """Estimates after one sample (all arrays ``(2,)`` are ``[front, rear]``).

    Attributes
    ----------
    vx, vy, yaw_rate : float
        Stage-2 posterior [m/s, m/s, rad/s].
    forces : ndarray, shape (3,)
        ``Fxf, Fyf, Fyr`` [N].
    slip_angles, normal_loads : ndarray, shape (2,)
        [rad], [N].
    mu, mu_std : ndarray, shape (2,)
        Friction posterior mean and standard deviation [-].
    excited : ndarray of bool, shape (2,)
    mu_obs, mu_obs_std : ndarray, shape (2,)
        Single-sample observation (module docstring); NaN / inf where not excited.
    """

    vx: float
    vy: float
    yaw_rate: float
    forces: NDArray[np.float64]
    slip_angles: NDArray[np.float64]
    normal_loads: NDArray[np.float64]
    mu: NDArray[np.float64]
    mu_std: NDArray[np.float64]
    excited: NDArray[np.bool_]
    mu_obs: NDArray[np.float64]
    mu_obs_std: NDArray[np.float64]


# -- models (compiled, vectorised over sigma points) --------------------------------


@njit(cache=True)
def force_transition(X, steer, dt, mass, iz, lf, lr):  # pragma: no cover - compiled
    """Stage-2 process model, eq. 9, for every row of ``X`` (N, 6) -> (N, 6).

    The velocity update uses :func:`_rotate_integrate` (exact rotation) instead
    of the Euler step; the yaw rate and the forces follow eq. 9.
    """
    c = np.cos(steer)
    s = np.sin(steer)
    out = X.copy()
    for i in range(X.shape[0]):
        vx = X[i, 0]
        r = X[i, 1]
        vy = X[i, 2]
        fxf = X[i, 3]
        fyf = X[i, 4]
        fyr = X[i, 5]
        ax = (fxf * c - fyf * s) / mass
        ay = (fxf * s + fyf * c + fyr) / mass
        vx_n, vy_n = _rotate_integrate(vx, vy, r, ax, ay, dt)
        out[i, 0] = vx_n
        out[i, 1] = r + dt * (lf * (fxf * s + fyf * c) - lr * fyr) / iz
        out[i, 2] = vy_n
    return out


@njit(cache=True)
def _rotate_integrate(vx, vy, r, ax, ay, dt):  # pragma: no cover - compiled
    """Body-frame velocity after ``dt`` at constant yaw rate ``r`` and acceleration ``(ax, ay)``.

    ``v' = Rot(-r dt) v + dt Rot(-r dt / 2) a``: the exact rotation of the velocity
    vector plus the midpoint-rotated acceleration. The Euler step of eq. 3 and
    eq. 9 (``vx' = vx + dt (ax + vy r)``) misses the second-order term
    ``-vx (r dt)² / 2``, which acts like an accelerometer bias of ``vx r² dt / 2``
    (0.07 m/s² at 3 m/s, 1.5 rad/s and 50 Hz) and appears as a bias in ``vy``.
    """
    th = r * dt
    c = np.cos(th)
    s = np.sin(th)
    ch = np.cos(0.5 * th)
    sh = np.sin(0.5 * th)
    return (c * vx + s * vy + dt * (ch * ax + sh * ay),
            -s * vx + c * vy + dt * (-sh * ax + ch * ay))


@njit(cache=True)
def force_measurement(X, steer, mass):  # pragma: no cover - compiled
    """Stage-2 measurement model, eq. 10 (sign of ``h5`` corrected), (N, 6) -> (N, 5)."""
    c = np.cos(steer)
    s = np.sin(steer)
    out = np.empty((X.shape[0], 5))
    for i in range(X.shape[0]):
        fxf = X[i, 3]
        fyf = X[i, 4]
        fyr = X[i, 5]
        out[i, 0] = X[i, 0]
        out[i, 1] = X[i, 1]
        out[i, 2] = X[i, 2]
        out[i, 3] = (fxf * c - fyf * s) / mass
        out[i, 4] = (fxf * s + fyf * c + fyr) / mass
    return out


@njit(cache=True)
def _brush(alpha, fz, mu, k):  # pragma: no cover - compiled
    """Scalar Fiala brush force, identical to :func:`roadgrip.tire.brush_force`."""
    a = min(max(alpha, -1.5), 1.5)
    z = np.tan(a)
    az = abs(z)
    if az < 3.0 * mu / k:
        return fz * (k * z - k * k * az * z / (3.0 * mu) + k * k * k * z * z * z / (27.0 * mu * mu))
    return fz * mu * (1.0 if z > 0 else (-1.0 if z < 0 else 0.0))


@njit(cache=True)
def _brush_slope(alpha, fz, mu, k):  # pragma: no cover - compiled
    """``dF / dalpha`` of the brush force [N/rad]."""
    a = min(max(alpha, -1.5), 1.5)
    z = np.tan(a)
    u = k * abs(z) / mu
    if u >= 3.0:
        return 0.0
    return fz * k * (1.0 - u / 3.0) ** 2 * (1.0 + z * z)


@njit(cache=True)
def _slip_sensitivity(alpha, fz, mu, k):  # pragma: no cover - compiled
    """``|dmu/dalpha|`` at constant force: ``|dF/dalpha| / |dF/dmu|`` of the brush model [1/rad].

    Infinite at zero slip and in the linear range (the force does not depend
    on ``mu`` there), zero in full sliding (the force does not depend on slip).
    """
    a = min(max(alpha, -1.5), 1.5)
    z = abs(np.tan(a))
    if z == 0.0:
        return np.inf
    u = k * z / mu
    if u >= 3.0:
        return 0.0
    dfdmu = fz * (k * k * z * z / (3.0 * mu * mu)) * (1.0 - 2.0 * u / 9.0)
    dfda = fz * k * (1.0 - u / 3.0) ** 2 * (1.0 + z * z)
    if dfdmu <= 0.0:
        return np.inf
    return dfda / dfdmu


@njit(cache=True)
def _brush_mu(force, alpha, fz, k):  # pragma: no cover - compiled
    """Scalar exact inversion of the brush model (see :func:`brush_mu_inverse`); inf if none."""
    a = min(max(alpha, -1.5), 1.5)
    z = np.tan(a)
    lin = fz * k * abs(z)
    if force * z <= 0.0 or lin <= 0.0 or fz <= 0.0:
        return np.inf
    rho = abs(force) / lin
    if rho >= 1.0:
        return np.inf
    if rho <= 1.0 / 3.0:
        return abs(force) / fz
    u = 0.5 * (9.0 - np.sqrt(max(81.0 - 108.0 * (1.0 - rho), 0.0)))
    return k * abs(z) / u


@njit(cache=True)
def _slip_bias_effect(force, alpha, fz, k, dalpha):  # pragma: no cover - compiled
    """Largest change of the friction that explains ``force`` when the slip angle moves by ``±dalpha``.

    Uses the exact brush inversion, so it also sees a bias that would move the
    tire between the adhesion and the sliding branch; inf where any of the
    three slip angles leaves no finite friction.
    """
    m0 = _brush_mu(force, alpha, fz, k)
    m1 = _brush_mu(force, alpha + dalpha, fz, k)
    m2 = _brush_mu(force, alpha - dalpha, fz, k)
    if not (np.isfinite(m0) and np.isfinite(m1) and np.isfinite(m2)):
        return np.inf
    return max(abs(m1 - m0), abs(m2 - m0))


@njit(cache=True)
def friction_measurement(M, alpha_f, alpha_r, fzf, fzr, kf, kr, mu_min, mu_max):  # pragma: no cover
    """Stage-3 measurement model, eq. 11: brush forces of each row ``[mu_f, mu_r]`` (N, 2) -> (N, 2)."""
    out = np.empty((M.shape[0], 2))
    for i in range(M.shape[0]):
        muf = min(max(M[i, 0], mu_min), mu_max)
        mur = min(max(M[i, 1], mu_min), mu_max)
        out[i, 0] = _brush(alpha_f, fzf, muf, kf)
        out[i, 1] = _brush(alpha_r, fzr, mur, kr)
    return out


# -- the compiled step ----------------------------------------------------------------


@njit(cache=True)
def _step(xe, Pe, xu, Pu, xm, Pm, up, dt, ax, ay, r, steer, vmeas, vxp, vyp, p, w6m, w6c, g6, w2m, w2c, g2, out):  # pragma: no cover
    """One sample through the three stages; updates the state arrays in place, fills ``out``."""
    m = p[_P.MASS]
    repairs = 0
    var_acc = p[_P.VAR_ACC] + p[_P.VAR_ACC_MODEL]
    # ---- stage 1: EKF (eq. 3-4, with accelerometer bias states) ----
    if dt > 0.0:
        vx = xe[0]
        vy = xe[1]
        # inputs over the step: mean of the samples at both ends (trapezoid rule)
        ra = 0.5 * (r + up[2])
        c = np.cos(ra * dt)
        s = np.sin(ra * dt)
        ch = np.cos(0.5 * ra * dt)
        sh = np.sin(0.5 * ra * dt)
        F = np.eye(4)
        F[0, 0] = c
        F[0, 1] = s
        F[1, 0] = -s
        F[1, 1] = c
        F[0, 2] = -dt * ch
        F[0, 3] = -dt * sh
        F[1, 2] = dt * sh
        F[1, 3] = -dt * ch
        axc = 0.5 * (ax + up[0]) - xe[2]
        ayc = 0.5 * (ay + up[1]) - xe[3]
        vxn, vyn = _rotate_integrate(vx, vy, ra, axc, ayc, dt)
        xe[0] = vxn
        xe[1] = vyn
        vg = p[_P.VAR_GYRO]
        Q = np.zeros((4, 4))
        Q[0, 0] = (var_acc + vg * vyn * vyn) * dt * dt
        Q[0, 1] = -vg * vyn * vxn * dt * dt
        Q[1, 0] = Q[0, 1]
        Q[1, 1] = (var_acc + vg * vxn * vxn) * dt * dt
        Q[2, 2] = p[_P.Q_BIAS] * dt
        Q[3, 3] = p[_P.Q_BIAS] * dt
        Pe[:, :] = F @ Pe @ F.T + Q
    up[0] = ax
    up[1] = ay
    up[2] = r
    # measured speed: mean wheel-frame speed of the wheels used (eq. 5); the front
    # wheels, steered by d, see vx cos d + (vy + lf r) sin d, the rear wheels vx
    fs = p[_P.FRONT_SHARE]
    cd = np.cos(steer)
    sd = np.sin(steer)
    H = np.array([[1.0 - fs + fs * cd, fs * sd, 0.0, 0.0]])
    resid = np.array([vmeas - (H[0, 0] * xe[0] + H[0, 1] * xe[1] + fs * sd * p[_P.LF] * r)])
    xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), resid, H, np.array([[p[_P.VAR_SPEED]]]))
    xe[:] = xn
    Pe[:, :] = Pn
    # body velocity from the localisation pose: bounds the drift of the integrated vy
    if p[_P.VAR_POSE] > 0.0 and dt > 0.0 and vyp == vyp and vxp == vxp:
        Hp = np.zeros((2, 4))
        Hp[0, 0] = 1.0
        Hp[1, 1] = 1.0
        vpose = p[_P.VAR_POSE] / dt
        xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), np.array([vxp - xe[0], vyp - xe[1]]), Hp,
                                  np.diag(np.array([vpose, vpose])))
        xe[:] = xn
        Pe[:, :] = Pn
    # standstill (zero-velocity update): vx = vy = 0 and the accelerometers read their biases
    if abs(vmeas) < 0.05 and abs(r) < 0.05:
        Hz = np.zeros((4, 4))
        Hz[0, 0] = 1.0
        Hz[1, 1] = 1.0
        Hz[2, 2] = 1.0
        Hz[3, 3] = 1.0
        Rz = np.diag(np.array([1e-4, 1e-4, var_acc, var_acc]))
        xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), np.array([-xe[0], -xe[1], ax - xe[2], ay - xe[3]]),
                                  Hz, Rz)
        xe[:] = xn
        Pe[:, :] = Pn
    # near-straight driving: linear-tire pseudo-measurement of vy (bounds its drift)
    ayc = ay - xe[3]
    if abs(ayc) < p[_P.AY_STRAIGHT]:
        wb = p[_P.LF] + p[_P.LR]
        a_lin = m * ayc * p[_P.LF] / (wb * p[_P.CR])
        vy_lin = p[_P.LR] * r - xe[0] * a_lin
        sd = abs(xe[0]) * (p[_P.SLIP_BIAS] + abs(a_lin)) + 0.01  # floor 1 cm/s at standstill
        H2 = np.array([[0.0, 1.0, 0.0, 0.0]])
        xn, Pn, _ = joseph_update(xe.copy(), Pe.copy(), np.array([vy_lin - xe[1]]), H2,
                                  np.array([[sd * sd]]))
        xe[:] = xn
        Pe[:, :] = Pn
    # ---- stage 2: UKF1 (eq. 6-10) ----
    if dt > 0.0:
        L, Pu_used, rep = psd_sqrt(Pu)
        repairs += rep
        X = sigma_points(xu, L, g6)
        Y = force_transition(X, steer, dt, m, p[_P.IZ], p[_P.LF], p[_P.LR])
        Qu = np.zeros((6, 6))
        qv = var_acc * dt * dt
        Qu[0, 0] = qv
        Qu[2, 2] = qv
        Qu[1, 1] = p[_P.Q_YAW] * dt * dt
        qf = p[_P.Q_FORCE] * dt * dt
        Qu[3, 3] = qf
        Qu[4, 4] = qf
        Qu[5, 5] = qf
        mean, cov = unscented_transform(Y, w6m, w6c, Qu)
        xu[:] = mean
        Pu[:, :] = 0.5 * (cov + cov.T)
    L, Pu_used, rep = psd_sqrt(Pu)
    repairs += rep
    X = sigma_points(xu, L, g6)
    Z = force_measurement(X, steer, m)
    z = np.array([xe[0], r, xe[1], ax - xe[2], ay - xe[3]])
    R = np.zeros((5, 5))
    R[0, 0] = Pe[0, 0]
    R[0, 2] = Pe[0, 1]
    R[2, 0] = Pe[1, 0]
    R[2, 2] = Pe[1, 1]
    R[1, 1] = p[_P.VAR_GYRO]
    R[3, 3] = var_acc + Pe[2, 2]
    R[4, 4] = var_acc + Pe[3, 3]
    xn, Pn, res2, S2 = ukf_correct(xu.copy(), Pu_used, X, Z, w6m, w6c, z, R)
    xu[:] = xn
    Pu[:, :] = Pn
    # ---- slip angles, loads, their uncertainty ----
    vx = xu[0]
    r_e = xu[1]
    vy = xu[2]
    sgn = 1.0 if vx >= 0.0 else -1.0
    u = sgn * np.sqrt(vx * vx + p[_P.V_EPS] * p[_P.V_EPS])
    lf = p[_P.LF]
    lr = p[_P.LR]
    qf_ = (vy + lf * r_e) / u
    qr_ = (vy - lr * r_e) / u
    alpha_f = steer - np.arctan(qf_)
    alpha_r = -np.arctan(qr_)
    # gradients of alpha wrt (vx, r, vy), first order
    cf = 1.0 / (1.0 + qf_ * qf_)
    cr = 1.0 / (1.0 + qr_ * qr_)
    gf = np.array([cf * qf_ / u, -cf * lf / u, -cf / u])
    gr = np.array([cr * qr_ / u, cr * lr / u, -cr / u])
    Pv = np.ascontiguousarray(Pu[:3, :3])
    # steering actuator: a commanded angle is reached with a lag; the part of the last
    # command changes not yet followed, |steer - low-pass(steer)|, is steering error
    tau_s = p[_P.STEER_TAU]
    if tau_s > 0.0:
        if up[5] != up[5]:
            up[5] = steer
        up[5] += min(dt / tau_s, 1.0) * (steer - up[5])
        steer_lag = steer - up[5]
    else:
        steer_lag = 0.0
    var_af = gf @ Pv @ gf + p[_P.VAR_STEER] + steer_lag * steer_lag
    var_ar = gr @ Pv @ gr
    ax_est = (xu[3] * np.cos(steer) - xu[4] * np.sin(steer)) / m
    wb = lf + lr
    dfz = m * ax_est * p[_P.H] / wb
    fzf = max(m * GRAVITY * lr / wb - dfz, 0.0)
    fzr = max(m * GRAVITY * lf / wb + dfz, 0.0)
    # ---- slip-angle consistency: rear slip against the linear tire at moderate ay ----
    ayb = abs(ay - xe[3])
    if (dt > 0.0 and abs(vx) >= p[_P.V_MIN] and p[_P.AY_STRAIGHT] <= ayb <= 2.0 * p[_P.AY_STRAIGHT]
            and fzr > 0.5 * m * GRAVITY * lf / (lf + lr)):
        e_lin = alpha_r - xu[5] / (p[_P.KR] * max(fzr, 1e-9))
        lam = min(dt / p[_P.CONSIST_TAU], 1.0)
        up[3] += lam * (e_lin * e_lin - up[3])
        if fzf > 0.0:
            e_lin_f = alpha_f - xu[4] / (p[_P.KF] * fzf)
            up[4] += lam * (e_lin_f * e_lin_f - up[4])
    # ---- stage 3: UKF2 (eq. 11-12) ----
    mu_min = p[_P.MU_MIN]
    mu_max = p[_P.MU_MAX]
    if dt > 0.0:
        Pm[0, 0] = min(Pm[0, 0] + p[_P.Q_MU] * dt, p[_P.MU_VAR0])
        Pm[1, 1] = min(Pm[1, 1] + p[_P.Q_MU] * dt, p[_P.MU_VAR0])
    prior_m0 = xm[0]
    prior_m1 = xm[1]
    prior_v0 = Pm[0, 0]
    prior_v1 = Pm[1, 1]
    prior_P = Pm.copy()
    exc_f = 0.0
    exc_r = 0.0
    r3f = np.inf
    r3r = np.inf
    bias_f = np.nan
    bias_r = np.nan
    obs_f = np.nan
    obs_r = np.nan
    obs_vf = np.inf
    obs_vr = np.inf
    if abs(vx) >= p[_P.V_MIN] and fzf > 0.0 and fzr > 0.0:
        kf = p[_P.KF]
        kr = p[_P.KR]
        sf = _brush_slope(alpha_f, fzf, min(max(xm[0], mu_min), mu_max), kf)
        sr = _brush_slope(alpha_r, fzr, min(max(xm[1], mu_min), mu_max), kr)
        me = p[_P.MODEL_ERR]
        R3 = np.zeros((2, 2))
        R3[0, 0] = Pu[4, 4] + sf * sf * var_af + (me * fzf) ** 2
        R3[1, 1] = Pu[5, 5] + sr * sr * var_ar + (me * fzr) ** 2
        r3f = R3[0, 0]
        r3r = R3[1, 1]
        L, Pm_used, rep = psd_sqrt(Pm)
        repairs += rep
        X = sigma_points(xm, L, g2)
        Z = friction_measurement(X, alpha_f, alpha_r, fzf, fzr, kf, kr, mu_min, mu_max)
        z = np.array([xu[4], xu[5]])
        xn, Pn, _, _ = ukf_correct(xm.copy(), Pm_used, X, Z, w2m, w2c, z, R3)
        clipped_f = not (mu_min < xn[0] < mu_max)
        clipped_r = not (mu_min < xn[1] < mu_max)
        xm[0] = min(max(xn[0], mu_min), mu_max)
        xm[1] = min(max(xn[1], mu_min), mu_max)
        Pm[:, :] = Pn
        # information gained per axle -> single-sample observation
        lam_f = 1.0 / Pm[0, 0] - 1.0 / prior_v0
        lam_r = 1.0 / Pm[1, 1] - 1.0 / prior_v1
        # robustness to a slip-angle bias, which does not average out over samples
        # a lateral-velocity bias of vy_bias_std is a slip-angle bias of vy_bias_std / |vx|
        sb = max(p[_P.SLIP_BIAS], p[_P.VY_BIAS] / abs(vx))
        sbf = np.sqrt(sb * sb + p[_P.STEER_BIAS] ** 2)
        bias_f = sbf * _slip_sensitivity(alpha_f, fzf, xm[0], kf)
        bias_r = sb * _slip_sensitivity(alpha_r, fzr, xm[1], kr)
        # slip angles measurably worse than assumed: test the whole inversion at that error
        sc = np.sqrt(up[3])
        if sc > sb:
            bias_f = max(bias_f, _slip_bias_effect(xu[4], alpha_f, fzf, kf, np.sqrt(sc * sc + sbf * sbf)))
            bias_r = max(bias_r, _slip_bias_effect(xu[5], alpha_r, fzr, kr, sc))
        # the same inversion across the slip angle's own uncertainty (z standard deviations):
        # a tire that may as well be in its linear range gives only a lower bound, |F| / Fz
        zs = p[_P.SLIP_Z]
        gate_f = 0.0
        gate_r = 0.0
        if zs > 0.0:
            gate_f = _slip_bias_effect(xu[4], alpha_f, fzf, kf, zs * np.sqrt(var_af + up[4]))
            gate_r = _slip_bias_effect(xu[5], alpha_r, fzr, kr, zs * np.sqrt(var_ar + up[3]))
        if (lam_f >= p[_P.EXC_PREC] * dt and dt > 0.0 and bias_f <= p[_P.MAX_BIAS] and not clipped_f
                and gate_f <= p[_P.MAX_BIAS]):
            obs_f = (xm[0] / Pm[0, 0] - prior_m0 / prior_v0) / lam_f
            if mu_min <= obs_f <= mu_max:
                exc_f = 1.0
                obs_vf = 1.0 / lam_f
            else:
                obs_f = np.nan
        if (lam_r >= p[_P.EXC_PREC] * dt and dt > 0.0 and bias_r <= p[_P.MAX_BIAS] and not clipped_r
                and gate_r <= p[_P.MAX_BIAS]):
            obs_r = (xm[1] / Pm[1, 1] - prior_m1 / prior_v1) / lam_r
            if mu_min <= obs_r <= mu_max:
                exc_r = 1.0
                obs_vr = 1.0 / lam_r
            else:
                obs_r = np.nan
        # a sample that fails the excitation test does not move that axle's estimate
        if exc_f < 0.5:
            xm[0] = prior_m0
            Pm[0, :] = prior_P[0, :]
            Pm[:, 0] = prior_P[:, 0]
        if exc_r < 0.5:
            xm[1] = prior_m1
            Pm[1, :] = prior_P[1, :]
            Pm[:, 1] = prior_P[:, 1]
    nis = res2 @ np.linalg.solve(S2, res2)
    out[_O.VX] = xu[0]
    out[_O.YAW_RATE] = xu[1]
    out[_O.VY] = xu[2]
    out[_O.FXF] = xu[3]
    out[_O.FYF] = xu[4]
    out[_O.FYR] = xu[5]
    out[_O.ALPHA_F] = alpha_f
    out[_O.ALPHA_R] = alpha_r
    out[_O.FZF] = fzf
    out[_O.FZR] = fzr
    out[_O.MU_F] = xm[0]
    out[_O.MU_R] = xm[1]
    out[_O.VAR_F] = Pm[0, 0]
    out[_O.VAR_R] = Pm[1, 1]
    out[_O.EXC_F] = exc_f
    out[_O.EXC_R] = exc_r
    out[_O.OBS_F] = obs_f
    out[_O.OBS_R] = obs_r
    out[_O.OBS_VAR_F] = obs_vf
    out[_O.OBS_VAR_R] = obs_vr
    out[_O.NIS2] = nis
    out[_O.REPAIRS] = repairs
    out[_O.VX_EKF] = xe[0]
    out[_O.VY_EKF] = xe[1]
    # stage 1 without bias states (zero bias variance): check its velocity block
    pe_ok = cholesky_lower(Pe)[1] if Pe[2, 2] > 0.0 else cholesky_lower(np.ascontiguousarray(Pe[:2, :2]))[1]
    pd_ok = pe_ok and cholesky_lower(Pu)[1] and cholesky_lower(Pm)[1]
    out[_O.PD_OK] = 1.0 if pd_ok else 0.0
    out[_O.FYF_VAR] = Pu[4, 4]
    out[_O.FYR_VAR] = Pu[5, 5]
    out[_O.ALPHA_F_VAR] = var_af
    out[_O.ALPHA_R_VAR] = var_ar
    out[_O.R3_F] = r3f
    out[_O.R3_R] = r3r
    out[_O.SYS_F] = bias_f if exc_f > 0.5 else np.nan
    out[_O.SYS_R] = bias_r if exc_r > 0.5 else np.nan


@njit(cache=True)
def _run(t, ax, ay, r, steer, speed, vxp, vyp, xe, Pe, xu, Pu, xm, Pm, up, t_prev, p, w6m, w6c, g6, w2m, w2c, g2):  # pragma: no cover
    """Compiled loop over samples; the state arrays are updated in place."""
    n = t.shape[0]
    out = np.empty((n, _O.SIZE))
    tp = t_prev
    for k in range(n):
        dt = t[k] - tp if tp == tp else 0.0  # no predict before the first sample
        _step(xe, Pe, xu, Pu, xm, Pm, up, dt, ax[k], ay[k], r[k], steer[k], speed[k], vxp[k], vyp[k], p,
              w6m, w6c, g6, w2m, w2c, g2, out[k])
        tp = t[k]
    return out


# -- noise, speed, parameters ---------------------------------------------------------


def _robust_noise(x: NDArray[np.float64]) -> float:
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    if d2.size < 10:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


_NOISE_FLOORS = {"accel_std": 0.02, "gyro_std": 0.002, "speed_std": 0.01}


def noise_from_drive(drive: Drive, speed: NDArray[np.float64] | None = None) -> dict[str, float]:
    """Estimate white-noise standard deviations of the inputs from the drive.

    The robust standard deviation (1.4826 MAD) of the second difference of a
    signal, divided by ``sqrt(6)``: a smooth signal contributes little to the
    second difference at the sampling rate, white noise contributes ``6 s²``.
    Floors (0.02 m/s², 0.002 rad/s, 0.01 m/s) keep the filters from trusting
    quantised or interpolated signals absolutely.

    Returns
    -------
    dict
        ``accel_std`` [m/s²] (the larger of ``ax``, ``ay``), ``gyro_std`` [rad/s],
        ``speed_std`` [m/s].
    """
    out = {
        "accel_std": max(_robust_noise(drive.col("ax")), _robust_noise(drive.col("ay"))),
        "gyro_std": _robust_noise(drive.col("yaw_rate")),
        "speed_std": _robust_noise(speed) if speed is not None else 0.0,
    }
    return {k: max(v, _NOISE_FLOORS[k]) for k, v in out.items()}


def measured_speed(drive: Drive, source: str = "auto") -> tuple[NDArray[np.float64], str, float]:
    """The stage-1 speed measurement (eq. 5) [m/s], a description, the share of front wheels.

    ``'wheels'``: mean of ``omega R`` over the undriven axle (front wheels for
    rear drive, rear wheels for front drive) or all four wheels for four-wheel
    drive. ``'motor_rpm'``: motor speed [rev/min] through the gear ratio,
    ``rpm 2 pi R / (60 i)``. ``'vx_motor'`` and ``'vx'``: those columns.
    ``'auto'`` takes the first available of wheels, vx, vx_motor, motor_rpm, but
    prefers ``vx`` to wheel speeds on a four-wheel-driven car (all wheels slip).
    The third value is the fraction of steered (front) wheels in the mean, which
    stage 1 uses to model their speed, ``vx cos d + (vy + lf r) sin d``.

    Raises
    ------
    DriveValidationError
        When the requested (or any, for ``'auto'``) source is missing.
    """
    veh = drive.vehicle
    if source == "auto":
        # undriven wheels measure the ground speed; on a four-wheel-driven car every
        # wheel slips under drive, so a measured vx (odometry, GNSS) comes first there
        order = ("vx", "wheels", "vx_motor", "motor_rpm") if veh.drive == "awd" else (
            "wheels", "vx", "vx_motor", "motor_rpm")
    else:
        order = (source,)
    for src in order:
        if src == "wheels" and drive.has_wheel_speeds:
            cols = {"fwd": ("omega_rl", "omega_rr"), "rwd": ("omega_fl", "omega_fr")}.get(
                veh.drive, ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
            )
            w = np.mean([drive.col(c) for c in cols], axis=0)
            share = sum(c.startswith("omega_f") for c in cols) / len(cols)
            return w * veh.wheel_radius, f"wheel speeds {'+'.join(cols)} x R", share
        if src in ("vx", "vx_motor") and drive.has(src):
            return drive.col(src), f"column {src}", 0.0
        if src == "motor_rpm" and drive.has("motor_rpm"):
            v = drive.col("motor_rpm") * 2 * np.pi * veh.wheel_radius / (60.0 * veh.gear_ratio)
            return v, "motor_rpm through the gear ratio (eq. 5)", 0.0
    raise DriveValidationError(
        f"drive from {drive.meta.source} has no speed measurement for the cascade "
        f"(source {source!r}; need wheel speeds omega_*, vx, vx_motor or motor_rpm)"
    )


def _params(vehicle: VehicleParams, cfg: CascadeConfig, noise: dict[str, float],
            front_share: float = 0.0) -> NDArray[np.float64]:
    p = np.zeros(_P.SIZE)
    p[_P.MASS] = vehicle.mass
    p[_P.IZ] = vehicle.yaw_inertia
    p[_P.LF] = vehicle.lf
    p[_P.LR] = vehicle.lr
    p[_P.H] = vehicle.cg_height
    p[_P.KF] = vehicle.cornering_stiffness_front / vehicle.fz_front
    p[_P.KR] = vehicle.cornering_stiffness_rear / vehicle.fz_rear
    p[_P.VAR_ACC] = noise["accel_std"] ** 2
    p[_P.VAR_GYRO] = noise["gyro_std"] ** 2
    p[_P.VAR_SPEED] = noise["speed_std"] ** 2
    p[_P.VAR_STEER] = cfg.steer_std**2
    p[_P.VAR_ACC_MODEL] = cfg.accel_model_std**2
    p[_P.Q_FORCE] = (vehicle.mass * cfg.jerk_std) ** 2
    # yaw acceleration error: the accelerometer model error across the wheelbase
    p[_P.Q_YAW] = (cfg.accel_model_std / vehicle.wheelbase) ** 2
    p[_P.Q_MU] = cfg.mu_rate_std**2
    p[_P.MU_VAR0] = cfg.mu_prior_std**2
    p[_P.MU_MIN], p[_P.MU_MAX] = cfg.mu_bounds
    p[_P.MODEL_ERR] = cfg.model_error
    p[_P.EXC_PREC] = 1.0 / cfg.excitation_std**2
    p[_P.V_MIN] = cfg.v_min
    p[_P.V_EPS] = cfg.v_eps
    p[_P.FRONT_SHARE] = front_share
    p[_P.SLIP_BIAS] = cfg.slip_bias_std
    p[_P.MAX_BIAS] = cfg.max_slip_bias_effect
    p[_P.CR] = vehicle.cornering_stiffness_rear
    p[_P.AY_STRAIGHT] = cfg.ay_straight
    p[_P.Q_BIAS] = cfg.accel_bias_rate_std**2 if cfg.accel_bias_std else 0.0
    p[_P.STEER_BIAS] = cfg.steer_bias_std
    p[_P.VY_BIAS] = cfg.vy_bias_std
    p[_P.CONSIST_TAU] = 5.0
    p[_P.VAR_POSE] = cfg.pose_velocity_std**2 * cfg.pose_velocity_corr_time
    p[_P.SLIP_Z] = cfg.slip_noise_z
    p[_P.STEER_TAU] = cfg.steer_response_time or 0.0
    return p


def _resolve_noise(cfg: CascadeConfig, drive: Drive | None, speed: NDArray[np.float64] | None,
                   speed_source: str = "") -> dict[str, float]:
    """Noise standard deviations: the config's, else the reader's, else estimated from the drive.

    A reader that resamples asynchronous streams may record the noise it measured
    on the native streams in ``meta.extra['sensor_noise']`` (``accel_std``,
    ``gyro_std``, and ``speed_std`` of the ``vx`` column), per tick of the
    drive's clock; :func:`noise_from_drive` on an upsampled, linearly
    interpolated signal would report a fraction of it (the frictionmaps runs:
    0.05 m/s² instead of about 1.9 m/s² on DS5, mean stage-2 NIS 126 instead of 2.8 for 5 dof).
    """
    given = {k: getattr(cfg, k) for k in _NOISE_FLOORS}
    if all(v is not None for v in given.values()):
        return {k: float(v) for k, v in given.items()}
    if drive is None:
        missing = [k for k, v in given.items() if v is None]
        raise ValueError(f"give {missing} in CascadeConfig or a drive to estimate them from")
    est = noise_from_drive(drive, speed)
    native = dict(drive.meta.extra.get("sensor_noise", {}) or {})
    if speed_source != "column vx":
        native.pop("speed_std", None)
    for k in _NOISE_FLOORS:
        if k in native and np.isfinite(native[k]) and native[k] > 0:
            est[k] = max(float(native[k]), _NOISE_FLOORS[k])
    return {k: float(given[k]) if given[k] is not None else est[k] for k in given}


# -- public API: init / step / object ---------------------------------------------------


def init(vehicle: VehicleParams, config: CascadeConfig, vx0: float = 0.0, noise: dict[str, float] | None = None) -> CascadeState:
    """Initial state: speed ``vx0`` [m/s], zero lateral velocity and forces, the friction prior.

    The initial covariances come from the noise model: speed-sensor variance for
    ``vx``, gyro variance for the yaw rate, ``(0.2 m/s)²`` for ``vy`` and
    ``(m g)²`` for each force (a force of the order of the weight is possible).
    """
    n = noise or {k: getattr(config, k) or _NOISE_FLOORS[k] for k in _NOISE_FLOORS}
    vmin = max(n["speed_std"], 0.05)
    xe = np.array([vx0, 0.0, 0.0, 0.0])
    b0 = config.accel_bias_std or 0.0
    Pe = np.diag([vmin**2, 0.2**2, b0**2, b0**2])
    xu = np.array([vx0, 0.0, 0.0, 0.0, 0.0, 0.0])
    fw = (vehicle.mass * GRAVITY) ** 2
    Pu = np.diag([vmin**2, max(n["gyro_std"], 0.01) ** 2, 0.2**2, fw, fw, fw])
    xm = np.full(2, config.mu_prior)
    Pm = np.eye(2) * config.mu_prior_std**2
    return CascadeState(float("nan"), xe, Pe, xu, Pu, xm, Pm, np.array([0.0, 0.0, 0.0, 0.0, 0.0, np.nan]))


class _Compiled(NamedTuple):
    p: NDArray[np.float64]
    w6m: NDArray[np.float64]
    w6c: NDArray[np.float64]
    g6: float
    w2m: NDArray[np.float64]
    w2c: NDArray[np.float64]
    g2: float


def _compile_args(vehicle: VehicleParams, config: CascadeConfig, noise: dict[str, float],
                  front_share: float = 0.0) -> _Compiled:
    w6 = merwe_weights(ForceState.SIZE, config.alpha, config.beta, config.kappa)
    w2 = merwe_weights(FrictionState.SIZE, config.alpha, config.beta, config.kappa)
    return _Compiled(_params(vehicle, config, noise, front_share), w6.wm, w6.wc, w6.gamma, w2.wm, w2.wc, w2.gamma)


def _estimate(row: NDArray[np.float64]) -> CascadeEstimate:
    exc = np.array([row[_O.EXC_F] > 0.5, row[_O.EXC_R] > 0.5])
    return CascadeEstimate(
        float(row[_O.VX]), float(row[_O.VY]), float(row[_O.YAW_RATE]),
        row[[_O.FXF, _O.FYF, _O.FYR]].copy(),
        row[[_O.ALPHA_F, _O.ALPHA_R]].copy(),
        row[[_O.FZF, _O.FZR]].copy(),
        row[[_O.MU_F, _O.MU_R]].copy(),
        np.sqrt(row[[_O.VAR_F, _O.VAR_R]]),
        exc,
        row[[_O.OBS_F, _O.OBS_R]].copy(),
        np.sqrt(row[[_O.OBS_VAR_F, _O.OBS_VAR_R]]),
    )


def _check_sample(sample: CascadeSample) -> None:
    for name, v in zip(CascadeSample._fields, sample, strict=True):
        if name in ("vx_pose", "vy_pose"):
            if np.isinf(v):
                raise ValueError(f"cascade sample field {name!r} is infinite (NaN marks a missing pose)")
            continue
        if not np.isfinite(v):
            raise ValueError(f"cascade sample field {name!r} is not finite: {v!r}")


def step(
    state: CascadeState,
    sample: CascadeSample,
    vehicle: VehicleParams,
    config: CascadeConfig,
    noise: dict[str, float],
    front_share: float = 0.0,
) -> tuple[CascadeState, CascadeEstimate]:
    """Pure single step of the cascade: returns the new state and the estimates.

    Parameters
    ----------
    state : CascadeState
    sample : CascadeSample
        SI inputs at time ``sample.t`` (> ``state.t``).
    vehicle : VehicleParams
    config : CascadeConfig
    noise : dict
        ``accel_std, gyro_std, speed_std`` (resolved, e.g. by :func:`noise_from_drive`).
    front_share : float
        Share of steered wheels in the speed measurement (:func:`measured_speed`).
    """
    _check_sample(sample)
    if state.t == state.t and sample.t <= state.t:
        raise ValueError(f"sample time {sample.t} does not follow the state time {state.t}")
    c = _compile_args(vehicle, config, noise, front_share)
    arrays = [np.array(a, dtype=float, copy=True) for a in state[1:]]
    out = _run(
        np.array([sample.t]), np.array([sample.ax]), np.array([sample.ay]),
        np.array([sample.yaw_rate]), np.array([sample.steer]), np.array([sample.speed]),
        np.array([sample.vx_pose]), np.array([sample.vy_pose]),
        *arrays, state.t, *c,
    )
    return CascadeState(float(sample.t), *arrays), _estimate(out[0])


def _drive_inputs(drive: Drive, config: CascadeConfig) -> tuple[dict[str, NDArray[np.float64]], str, float]:
    drive.require("t", "ax", "ay", "yaw_rate", "steer", why="the cascade needs IMU and steering")
    speed, src, share = measured_speed(drive, config.speed_source)
    cols = {c: drive.col(c) for c in ("t", "ax", "ay", "yaw_rate", "steer")}
    cols["speed"] = np.asarray(speed, dtype=float)
    for k, v in cols.items():
        if not np.all(np.isfinite(v)):
            raise DriveValidationError(f"cascade input {k!r} holds NaN/inf")
    n = len(cols["t"])
    use_pose = config.pose_velocity_std > 0 and drive.has("vx_pose", "vy_pose")
    for c in ("vx_pose", "vy_pose"):
        v = np.asarray(drive.col(c), dtype=float) if use_pose else np.full(n, np.nan)
        if np.isinf(v).any():
            raise DriveValidationError(f"cascade input {c!r} holds inf (NaN marks a missing pose)")
        cols[c] = v
    return cols, src, share


def _has_standstill(cols: dict[str, NDArray[np.float64]], min_duration: float = 1.0) -> bool:
    """True when the speed stays below 0.05 m/s for ``min_duration`` [s] somewhere."""
    still = (np.abs(cols["speed"]) < 0.05) & (np.abs(cols["yaw_rate"]) < 0.05)
    if not still.any():
        return False
    t = cols["t"]
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(np.int8), [0]])))
    starts, ends = edges[::2], edges[1::2] - 1
    return bool(np.any(t[ends] - t[starts] >= min_duration))


def run(drive: Drive, config: CascadeConfig | None = None) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Run the compiled cascade over a whole drive.

    Returns
    -------
    out : ndarray, shape (n, n_outputs)
        Raw output rows (:func:`result_table` turns them into the table).
    info : dict
        ``noise`` (resolved standard deviations), ``speed_source``, final ``state``.
    """
    config = config or CascadeConfig()
    cols, src, share = _drive_inputs(drive, config)
    if config.accel_bias_std is None:
        config = dataclasses.replace(config, accel_bias_std=0.3 if _has_standstill(cols) else 0.0)
    if config.steer_response_time is None:
        command = bool(drive.meta.extra.get("steer_is_command", False))
        config = dataclasses.replace(config, steer_response_time=0.1 if command else 0.0)
    noise = _resolve_noise(config, drive, cols["speed"], src)
    state = init(drive.vehicle, config, float(cols["speed"][0]), noise)
    arrays = [np.array(a, copy=True) for a in state[1:]]
    c = _compile_args(drive.vehicle, config, noise, share)
    out = _run(cols["t"], cols["ax"], cols["ay"], cols["yaw_rate"], cols["steer"], cols["speed"],
               cols["vx_pose"], cols["vy_pose"], *arrays, float("nan"), *c)
    final = CascadeState(float(cols["t"][-1]), *arrays)
    return out, {"noise": noise, "speed_source": src, "front_share": share, "state": final,
                 "config": config}


class Cascade:
    """Online wrapper: ``step(sample)`` one sample at a time, ``run(drive)`` for a record.

    Parameters
    ----------
    vehicle : VehicleParams
    config : CascadeConfig, optional
    noise : dict, optional
        Sensor noise standard deviations; required for online use unless all
        three are set in ``config``.
    front_share : float
        Share of steered wheels in the speed measurement (:func:`measured_speed`).

    Attributes
    ----------
    state_ : CascadeState
        Posterior after the last sample.
    """

    def __init__(self, vehicle: VehicleParams, config: CascadeConfig | None = None,
                 noise: dict[str, float] | None = None, front_share: float = 0.0) -> None:
        self.vehicle = vehicle
        self.front_share = float(front_share)
        self.config = config or CascadeConfig()
        self.noise = noise
        self.state_: CascadeState | None = None

    def step(self, sample: CascadeSample) -> CascadeEstimate:
        """Process one sample (the first one initialises the speed)."""
        if self.noise is None:
            self.noise = _resolve_noise(self.config, None, None)
        if self.state_ is None:
            self.state_ = init(self.vehicle, self.config, sample.speed, self.noise)
        self.state_, est = step(self.state_, sample, self.vehicle, self.config, self.noise,
                                self.front_share)
        return est

    def run(self, drive: Drive) -> EstimateResult:
        """Whole drive; see :func:`run_cli` for the table."""
        return _result(drive, self.config)


def samples(drive: Drive, config: CascadeConfig | None = None) -> list[CascadeSample]:
    """The drive as a list of :class:`CascadeSample` (for online replay)."""
    cols, _, _ = _drive_inputs(drive, config or CascadeConfig())
    return [CascadeSample(*v) for v in zip(cols["t"], cols["ax"], cols["ay"], cols["yaw_rate"],
                                           cols["steer"], cols["speed"], cols["vx_pose"], cols["vy_pose"],
                                           strict=True)]


# -- result table and CLI --------------------------------------------------------------


def brush_mu_inverse(force, slip, fz, c_stiff):
    """Invert the brush model: the friction ``mu`` that produces ``force`` at ``slip``.

    Closed form: with ``u = k |tan(slip)| / mu`` the adhesion branch reads
    ``|F| / (Fz k |tan(slip)|) = 1 - u/3 + u²/27`` for ``u < 3``, a quadratic in
    ``u``; its root in ``[0, 3)`` gives ``mu``. Where the ratio is at most 1/3
    the tire slides fully and ``mu = |F| / Fz`` exactly.

    Parameters
    ----------
    force : array_like
        Lateral force [N] (same sign convention as ``slip``).
    slip : array_like
        Slip angle [rad].
    fz : array_like
        Normal load [N], > 0.
    c_stiff : array_like
        Normalised cornering stiffness ``C / Fz`` [1/rad].

    Returns
    -------
    mu : ndarray
        Friction [-]; ``inf`` where no finite value fits.
    sliding : ndarray of bool
        The whole contact patch slides (saturated tire): ``mu = |F| / Fz``, and
        the force no longer depends on the slip.
    identifiable : ndarray of bool
        False where the force is at or above the linear-tire force
        ``Fz k tan(slip)`` (any large ``mu`` fits; the data carry only a lower
        bound), at zero slip, or where force and slip have opposite signs.

    Examples
    --------
    >>> from roadgrip.tire import brush_force
    >>> f = brush_force(0.05, 20.0, 0.6, 7.0)
    >>> mu, sliding, ok = brush_mu_inverse(f, 0.05, 20.0, 7.0)
    >>> round(float(mu), 12), bool(sliding), bool(ok)
    (0.6, False, True)
    """
    force = np.asarray(force, dtype=float)
    z = np.tan(np.clip(np.asarray(slip, dtype=float), -1.5, 1.5))
    fz = np.asarray(fz, dtype=float)
    k = np.asarray(c_stiff, dtype=float)
    if np.any(fz <= 0) or np.any(k <= 0):
        raise ValueError("normal load and cornering stiffness must be positive")
    force, z, fz, k = np.broadcast_arrays(force, z, fz, k)
    lin = fz * k * np.abs(z)
    same_sign = force * z > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(lin > 0, np.abs(force) / np.where(lin > 0, lin, 1.0), np.inf)
    sliding = same_sign & (rho <= 1.0 / 3.0)
    identifiable = same_sign & (rho < 1.0)
    adh = identifiable & ~sliding
    disc = np.sqrt(np.maximum(81.0 - 108.0 * (1.0 - np.where(adh, rho, 1.0)), 0.0))
    u = 0.5 * (9.0 - disc)
    mu = np.full(force.shape, np.inf)
    mu = np.where(sliding, np.abs(force) / fz, mu)
    with np.errstate(divide="ignore"):
        mu = np.where(adh, k * np.abs(z) / np.where(adh, u, 1.0), mu)
    return mu, sliding, identifiable


def result_table(drive: Drive, out: NDArray[np.float64]) -> pd.DataFrame:
    """Turn raw output rows into the estimates table (contract columns + extras)."""
    o = _O
    std_f = np.sqrt(out[:, o.VAR_F])
    std_r = np.sqrt(out[:, o.VAR_R])
    exc_f = out[:, o.EXC_F] > 0.5
    exc_r = out[:, o.EXC_R] > 0.5
    tab = {
        "t": drive.t,
        "mu_front": out[:, o.MU_F],
        "mu_rear": out[:, o.MU_R],
        "mu_front_lower": np.maximum(out[:, o.MU_F] - Z95 * std_f, 0.0),
        "mu_front_upper": out[:, o.MU_F] + Z95 * std_f,
        "mu_rear_lower": np.maximum(out[:, o.MU_R] - Z95 * std_r, 0.0),
        "mu_rear_upper": out[:, o.MU_R] + Z95 * std_r,
        "excited": exc_f | exc_r,
        "vx": out[:, o.VX],
        "vy": out[:, o.VY],
        "yaw_rate_est": out[:, o.YAW_RATE],
        "Fxf": out[:, o.FXF],
        "Fyf": out[:, o.FYF],
        "Fyr": out[:, o.FYR],
        "Fyf_std": np.sqrt(out[:, o.FYF_VAR]),
        "Fyr_std": np.sqrt(out[:, o.FYR_VAR]),
        "alpha_f": out[:, o.ALPHA_F],
        "alpha_r": out[:, o.ALPHA_R],
        "alpha_f_std": np.sqrt(out[:, o.ALPHA_F_VAR]),
        "alpha_r_std": np.sqrt(out[:, o.ALPHA_R_VAR]),
        "force_noise_front": np.sqrt(out[:, o.R3_F]),
        "force_noise_rear": np.sqrt(out[:, o.R3_R]),
        "Fzf": out[:, o.FZF],
        "Fzr": out[:, o.FZR],
        "mu_front_std": std_f,
        "mu_rear_std": std_r,
        "excited_front": exc_f,
        "excited_rear": exc_r,
        "mu_front_obs": out[:, o.OBS_F],
        "mu_front_obs_std": np.sqrt(out[:, o.OBS_VAR_F]),
        "mu_rear_obs": out[:, o.OBS_R],
        "mu_rear_obs_std": np.sqrt(out[:, o.OBS_VAR_R]),
        "mu_front_obs_sys": out[:, o.SYS_F],
        "mu_rear_obs_sys": out[:, o.SYS_R],
        "vx_ekf": out[:, o.VX_EKF],
        "vy_ekf": out[:, o.VY_EKF],
    }
    if drive.has("x", "y"):
        x, y = drive.col("x"), drive.col("y")
        tab["x"], tab["y"] = x, y
        if drive.has("psi"):
            c, s = np.cos(drive.col("psi")), np.sin(drive.col("psi"))
            veh = drive.vehicle
            tab["x_front"], tab["y_front"] = x + veh.lf * c, y + veh.lf * s
            tab["x_rear"], tab["y_rear"] = x - veh.lr * c, y - veh.lr * s
    return pd.DataFrame(tab)


def _result(drive: Drive, config: CascadeConfig) -> EstimateResult:
    meta: dict[str, Any] = {}
    with timed(meta, drive.n, drive.duration):
        out, info = run(drive, config)
    table = result_table(drive, out)
    last = table.iloc[-1]
    wf, wr = 1.0 / last["mu_front_std"] ** 2, 1.0 / last["mu_rear_std"] ** 2
    mp = (wf * last["mu_front"] + wr * last["mu_rear"]) / (wf + wr)
    sd = 1.0 / np.sqrt(wf + wr)
    meta["summary"] = {"MostProbable": float(mp), "LowerBound": float(max(mp - Z95 * sd, 0.0)),
                       "UpperBound": float(mp + Z95 * sd)}
    meta["diagnostics"] = {
        "speed source": info["speed_source"],
        "accel noise std [m/s2]": info["noise"]["accel_std"],
        "gyro noise std [rad/s]": info["noise"]["gyro_std"],
        "speed noise std [m/s]": info["noise"]["speed_std"],
        "excited front [%]": float(100 * table["excited_front"].mean()),
        "excited rear [%]": float(100 * table["excited_rear"].mean()),
        "mean NIS stage 2 (5 dof)": float(np.mean(out[:, _O.NIS2])),
        "covariance repairs": int(out[:, _O.REPAIRS].sum()),
        "samples with all covariances positive definite [%]": float(100 * out[:, _O.PD_OK].mean()),
    }
    meta["config"] = dataclasses.asdict(info["config"])
    return EstimateResult("cascade", conform(pd.DataFrame(table)), meta)


def run_cli(drive: Drive, request: EstimateRequest) -> EstimateResult:
    """``roadgrip estimate --method cascade``: run over a drive, optional figure.

    ``request.options`` may hold :class:`CascadeConfig` fields; options of other
    methods (particles, basis, calibration, curves) are rejected.
    """
    request.reject("cascade", "particles", "basis", "calibration", "curves_path", "curve_times")
    config = CascadeConfig.from_options(dict(request.options or {}))
    result = _result(drive, config)
    if request.plot_path:
        from roadgrip.plots.cascade import plot_cascade

        plot_cascade(result, drive, request.plot_path)
    return result
