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
with the rotation of the velocity vector over the step made exact
(:func:`~roadgrip.estimators.cascade.model.rotate_integrate`) and the inputs
integrated by the trapezoid rule (the Euler form with the inputs of one end of
the step biases ``vy`` at the yaw rates of a small car). The Jacobian of the velocity part is ``F = Rot(-r T)``.

The state also holds the accelerometer biases ``bx, by`` (random walks,
subtracted from ``ax, ay`` here and in stage 2), learnt at standstill by a
zero-velocity update (the accelerometers then read their biases) and while
driving through the speed measurement. A sensor 2 degrees off level reads
0.34 m/s² of gravity, which stage 1 would otherwise take for ``vy r`` and turn
into a lateral-velocity error of ``0.34 / r`` m/s. The bias states are switched on by
the first standstill of at least 1 s (``accel_bias_std=None``), which makes them
observable, and are off before it unless configured.

On straights (yaw rate near zero) ``vy`` is not observable from ``vx`` and its
integral drifts with the accelerometer noise. Below a lateral acceleration of
``ay_straight`` stage 1 therefore adds a pseudo-measurement from the linear
tire, ``vy = lr r - vx alpha_r`` with ``alpha_r = m ay lf / (l C_r)``, standard
deviation ``|vx| (slip_bias_std + |alpha_r|) + 0.01 m/s``. It is off in
cornering, where the tires may be nonlinear and the friction information lies.

*Pose velocity.* When the drive carries a body velocity differentiated from a
localisation pose (columns ``vx_pose, vy_pose``, e.g. the particle-filter pose
of the F1/10 runs, :func:`roadgrip.signals.body_velocity_from_pose`), stage 1
fuses it as a direct measurement of ``[vx, vy]`` with standard deviation
``pose_velocity_std``; NaN marks samples without one (near localisation jumps).
The pose error is correlated over the differentiation window
(``pose_velocity_corr_time``), so each sample's variance is inflated by
``corr_time / T``: a window counts as one independent measurement. This bounds
the drift of the integrated ``vy`` in cornering, where the straight-driving
pseudo-measurement is off.

The inputs ``u = [ax, ay, r]`` are measured, so the state noise follows from the
sensor noise: ``Q1 = T² (diag(sa², sa²) + sr² g gᵀ)`` with ``g = [vy, -vx]``
(first-order propagation of accelerometer noise ``sa`` and gyro noise ``sr``;
``sa²`` includes the accelerometer model error ``accel_model_std²``, which stands
for bias, road grade and mounting offset), ``R1 = sv²`` the speed-sensor noise.
The measured speed (eq. 5) is the mean wheel speed of the undriven axle, a
measured ``vx`` column (preferred on four-wheel-driven cars, whose wheels all
slip under drive; else all four wheels), or the motor speed through the gear
ratio ``rpm 2 pi R / (60 i)``
(:func:`~roadgrip.estimators.cascade.inputs.measured_speed`). Steered front wheels
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
longitudinal load transfer (:func:`roadgrip.signals.axle_loads`) and normalised
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
error (:func:`~roadgrip.estimators.cascade.model.slip_bias_effect`), which also
catches a bias that would move the tire between adhesion and sliding. The front axle's residual
``alpha_f - Fyf / C_f`` is tracked the same way. That check holds at moderate ``a_y``
only: the slip-angle errors of uncalibrated sensors (accelerometer scale, roll) change
with the lateral acceleration, by sign too, and above the band the tire is no longer
linear (on the F1/10 patch track at 2-3 m/s² its residual is the tire's curvature, 0.036 rad rms,
against a slip-angle error of 0.004 rad). With a pose velocity the slip angles are also checked
without a tire model, at every ``a_y``: the running mean (2 s) of the stage-2 ``vy`` minus
the pose's is their lateral-velocity bias, ``/ |vx|`` a slip-angle bias on both axles
(:func:`~roadgrip.estimators.cascade.kernel.pose_slip_error`, the bias beyond the pose's
own noise); the larger of the two checks is used. Before either check has evidence,
``slip_error_prior`` is assumed (0 by default: exact until shown otherwise). Neither
check follows a change faster than its window: an accelerometer that lags the gyro by
``d`` puts ``d`` times each change of ``a_y`` into ``vy`` at once, so with
``accel_latency_std`` (0 by default: one clock) the slip angles' error assumed grows by
``accel_latency_std (a_y - mean a_y) / |vx|``, the mean over the checks' window
(:func:`~roadgrip.estimators.cascade.kernel.latency_slip_error`).

The last test concerns the slip angle's *random* error: the exact inversion is
repeated at ``alpha ± z sqrt(var(alpha) + e²)`` (``z = slip_noise_z``,
``var(alpha)`` from the stage-2 covariance, ``e`` the axle's consistency
residual above) and must move by at most ``max_slip_bias_effect``. Without
it, a sample whose slip angle is overestimated lands on the sliding branch of
the brush model, where the local slope says the force no longer depends on the
slip, and reports ``mu = |F| / Fz``: the grip *used*, not the peak. A tire
that, within its slip uncertainty, may as well be in its linear range gives
only the lower bound ``|F| / Fz``, which no Gaussian observation expresses, so
such samples are not excited. On logs whose slip angles are much worse than
assumed, few samples count as excited and the map keeps its prior.

A sample that fails the test for an axle leaves that axle's estimate where it
was (the update is discarded), so weak and possibly biased information from
the linear range does not move the friction estimate; its variance keeps
growing by the random walk.

Below ``v_min`` the slip angles are not defined well enough and stage 3 makes
no update. An update whose mean leaves the physical range ``mu_bounds`` is
projected back onto it and does not count as excited (the data then say only
that ``mu`` lies at or beyond the bound, which no Gaussian observation states).

Sensor noise: see :mod:`roadgrip.estimators.cascade.inputs`.

Modules
-------
==============  ==========================================================
config          :class:`CascadeConfig`, :func:`prior_band`
model           state layouts, stage-2 force models, brush tire (compiled)
layout          state, output and constant layouts of the compiled step
kernel          the compiled step and loop
inputs          measured speed, sensor noise, per-sample records
running_noise   noise levels and biases estimated from the samples so far
result          estimates table, summary, diagnostics
estimator       ``prepare`` / ``init`` / ``step`` / ``run``, :data:`ESTIMATOR`
==============  ==========================================================
"""

from roadgrip.estimators.cascade.config import SPEED_SOURCES, CascadeConfig, prior_band
from roadgrip.estimators.cascade.estimator import (
    ESTIMATOR,
    CascadeState,
    init,
    prepare,
    run,
    run_filter,
    step,
)
from roadgrip.estimators.cascade.inputs import (
    CascadeSample,
    CascadeSamples,
    given_noise,
    measured_speed,
)
from roadgrip.estimators.cascade.kernel import Out
from roadgrip.estimators.cascade.model import (
    ForceMeasurement,
    ForceState,
    FrictionState,
    VelocityState,
    brush_mu_inverse,
    force_measurement,
    force_transition,
    friction_measurement,
    rotate_integrate,
)

__all__ = [
    "ESTIMATOR",
    "SPEED_SOURCES",
    "CascadeConfig",
    "CascadeSample",
    "CascadeSamples",
    "CascadeState",
    "ForceMeasurement",
    "ForceState",
    "FrictionState",
    "Out",
    "VelocityState",
    "brush_mu_inverse",
    "force_measurement",
    "force_transition",
    "friction_measurement",
    "given_noise",
    "init",
    "measured_speed",
    "prepare",
    "prior_band",
    "rotate_integrate",
    "run",
    "run_filter",
    "step",
]
