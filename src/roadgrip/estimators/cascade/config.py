"""Configuration of the Kalman cascade (paper 003): noise model, excitation tests, options."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from roadgrip.constants import Z95
from roadgrip.estimators.protocol import EstimatorConfig

__all__ = ["SPEED_SOURCES", "CascadeConfig", "prior_band"]

SPEED_SOURCES = ("auto", "wheels", "vx", "vx_motor", "motor_rpm")
"""Accepted ``speed_source`` values (:func:`roadgrip.estimators.cascade.inputs.measured_speed`)."""


@dataclass(frozen=True)
class CascadeConfig(EstimatorConfig):
    """Noise model and options of the cascade (SI units).

    ``None`` marks a value derived from the drive in ``prepare`` (recorded in
    ``DriveInfo.derived``); the configuration itself is never changed.

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
    mu_length : float
        Correlation length of the road friction [m]: over a distance ``d`` the
        friction state returns to the prior by the factor ``exp(-d / mu_length)``
        (mean and information), so that a band never carries the friction of a
        place the car has left into a new one. 0: no return (the paper's
        random walk in time alone).
    mu_prior : float
        Initial friction estimate [-], and the value the state returns to.
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
    slip_error_prior : float
        Slip-angle error [rad] assumed before the data have shown the slip angles' accuracy
        (module docstring of :mod:`roadgrip.estimators.cascade`). The band's consistency
        residual starts from its square, weighted as two seconds of samples in the band and
        fading as the band's or the kinematic check's evidence grows; the kinematic check
        (the slip angles' ``vy`` against the pose's) keeps the part of it its pose noise has
        not yet resolved. Uncalibrated production sensors put the slip angles 0.02-0.04 rad
        off; but 0.03 costs the F1/10 patch track the observations of its first corner, 1-2 s
        after the start, before its pose (0.06 m/s at 3 m/s) can resolve the bias below
        0.01 rad (docs/validation-cascade.md). 0, the default: exact until the checks show
        otherwise.
    accel_latency_std : float
        Standard deviation [s] of the accelerometer's latency behind the gyro's that the
        drive may carry (:func:`~roadgrip.estimators.cascade.kernel.latency_slip_error`).
        Stage 1 integrates ``ay - r vx``, so a latency ``d`` turns every change of the
        lateral acceleration into a lateral-velocity error ``d`` times that change, faster
        than the checks' 2 s window follows: the slip angles are assumed that much less
        accurate while the lateral acceleration departs from its running mean. 0, the
        default: one clock (the accelerometer and gyro of one device, or a drive aligned by a
        vehicle file's calibration, ``roadgrip vehicle fit``). Separate, unaligned messages
        need the spread of their latencies: 0.06 s for the simulator's realistic sensors
        (two independent 0-150 ms latencies), where 0 leaves observations 0.02 rad off in the
        transients (``docs/validation-cascade.md``); it costs the observations of every
        transient, the more the slower the car.
    max_slip_bias_effect : float
        A sample counts as excited only if a slip-angle error of ``slip_bias_std``
        would move its ``mu`` observation by at most this much [-]: close to the
        linear range of the tire, ``mu`` follows from the small curvature of the
        force and any slip bias maps into a large friction error.
    max_slip_ratio : float
        A sample counts as excited only while its slip angle, raised by
        ``slip_noise_z`` of its standard deviations, lies at most this multiple
        of the brush model's sliding slip angle ``atan(3 mu / k)``: far past its
        peak a real tire's force falls below the peak, so the force there is
        only a lower bound of the friction.
    peak_model_error : float
        Relative error of the friction the brush model reads from a tire of
        another shape [-] (the multi-body engine's Pacejka tires read 5-8 % high
        on gravel): the systematic part of each single-sample observation
        (``mu_<axle>_obs_sys``), together with the slip-angle bias's effect; it
        does not shrink when a map cell fuses many observations.
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
    pose_window : float
        Window [s] over which the body velocity is differentiated from the pose
        when the drive has ``x, y, psi`` but no ``vx_pose, vy_pose`` columns
        (its noise is estimated from the pose, its correlation time is the
        window); 0 does not derive it.
    wheel_slip_stiffness : float
        Normalised longitudinal slip stiffness ``C_x = (Fx / Fz) / slip`` [-] of
        the wheels the speed is measured with: under a deceleration (or, on
        driven wheels, an acceleration) ``a`` they slip by about ``|a| / (g C_x)``,
        which is added to the speed measurement's standard deviation as
        ``|v| |a| / (g C_x)``. 0 ignores wheel slip.
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

    method: ClassVar[str] = "cascade"

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
    mu_length: float = 5.0
    mu_prior: float = 0.7
    mu_prior_std: float = 0.4
    mu_bounds: tuple[float, float] = (0.05, 2.0)
    model_error: float = 0.02
    excitation_std: float = 0.5
    slip_bias_std: float = 0.01
    vy_bias_std: float = 0.03
    slip_error_prior: float = 0.0
    max_slip_bias_effect: float = 0.1
    max_slip_ratio: float = 2.0
    peak_model_error: float = 0.05
    slip_noise_z: float = 2.0
    ay_straight: float = 1.0
    pose_velocity_std: float = 0.1
    pose_velocity_corr_time: float = 0.3
    pose_window: float = 1.0
    accel_latency_std: float = 0.0
    wheel_slip_stiffness: float = 10.0
    v_min: float = 1.0
    v_eps: float = 0.1
    speed_source: str = "auto"
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0

    def __post_init__(self) -> None:
        if not (isinstance(self.mu_bounds, tuple) and len(self.mu_bounds) == 2):
            raise ValueError(f"cascade option 'mu_bounds' must be a pair (low, high), got {self.mu_bounds!r}")
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
            raise ValueError(f"cascade option 'mu_bounds' needs 0 < mu_bounds[0] < mu_prior < mu_bounds[1], "
                             f"got {self.mu_bounds}, {self.mu_prior}")
        if self.speed_source not in SPEED_SOURCES:
            raise ValueError(f"cascade option 'speed_source' must be one of {SPEED_SOURCES}, got {self.speed_source!r}")


def prior_band(config: CascadeConfig) -> tuple[float, float]:
    """The 95 % summary band before any friction information [-].

    Both axles at the prior ``N(mu_prior, mu_prior_std²)``, combined as the
    summary combines them (inverse-variance weights): standard deviation
    ``mu_prior_std / sqrt(2)``, lower end clipped at 0.
    """
    sd = 1.0 / np.sqrt(2.0 / config.mu_prior_std**2)
    return max(config.mu_prior - Z95 * sd, 0.0), config.mu_prior + Z95 * sd
