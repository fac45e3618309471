r"""Vehicle identification from a drive: what the estimators need and users rarely know.

``roadgrip vehicle fit`` identifies, each with a standard error and a status (``'fitted'``
or ``'undetermined'`` with the reason; an undetermined value keeps the base vehicle's):

===========================  ==========================================================
quantity                     evidence
===========================  ==========================================================
accelerometer (a_y) delay    ``a_y`` against ``v_x r`` (+ ``dv_y/dt`` with a pose), vs the gyro
                             (:func:`roadgrip.sensor_delay.estimate_delay`); without a pose
                             undetermined where the sideslip rate lends ``a_y`` more than
                             ``MAX_SIDESLIP_LAG`` (:func:`sideslip_lag`)
``a_x``'s own delay          the integral of ``a_x + v_y r`` against the pose's speed, plus the
                             pose's delay (``a_x`` may be a message of its own; without a
                             pose: undetermined, ``a_y``'s kept)
wheel-speed / vx delay       ``d v_x/dt`` against ``a_x + v_y r`` (outside braking), plus
                             ``a_x``'s delay (else ``a_y``'s)
pose delay                   ``dpsi/dt`` against the gyro
pose heading bias            the constant of the rear axle's slip against the pose's ``v_y``
                             (below)
gyro scale and bias          ``r = s dpsi/dt + b`` against the pose's heading
                             (:mod:`~roadgrip.inference.gyro_fit`); the rest of the fit
                             reads the corrected gyro
steering delay, offset,      the linear single-track identity (below), by least squares
scale, cornering stiffness   over the linear-range samples, the delay by a profile
per axle
accelerometer gain and bias  ``a_y = g_y v_x r + b_y``; ``a_x = g_x dv_x/dt + b_x``
wheel radius                 undriven wheels' ``omega`` against the pose speed or ``vx``
===========================  ==========================================================

**Single-track identity.** With the linear tires ``F_yf = C_f alpha_f``, ``F_yr = C_r alpha_r``,
``alpha_f = delta - (v_y + l_f r)/v_x``, ``alpha_r = -(v_y - l_r r)/v_x`` and the axle forces
from Newton and Euler, ``F_yf = (m l_r a_y + I_z r')/l``, ``F_yr = (m l_f a_y - I_z r')/l``,
the unmeasured ``v_y`` cancels from ``F_yf/C_f - F_yr/C_r``:

    ``delta = l r / v_x + (m a_y / l) K + (r' / l) J``,
    ``K = l_r/C_f - l_f/C_r``,  ``J = I_z (1/C_f + 1/C_r)``,

at every instant, not only in steady state. The road-wheel angle is ``delta = s
steer(t - d) + delta_0`` (scale ``s``, offset ``delta_0``, delay ``d``), so the measured
steering is linear in ``[l r/v_x, 1, m a_y/l, r'/l]`` with coefficients ``1/s,
-delta_0/s, K/s, J/s``. ``K`` and ``J`` give both stiffnesses for a known ``I_z``
(``1/C_f = (K + l_f J/I_z)/l``, ``1/C_r = (l_r J/I_z - K)/l``); the yaw inertia itself
would need ``v_y`` and is kept from the base vehicle. Samples: ``v_x >= V_MIN``,
``|a_y| < 0.4 mu g`` (linear range), ``|a_x| < 0.2 g``, none within reach of a value the
logger held (:func:`~roadgrip.inference.least_squares.held_samples`: a hold is the channel
late by its length). ``a_y`` is the accelerometer's reading over ``1 + g roll_gradient``
(a body-fixed sensor in a rolled body reads ``g`` times the roll angle besides).

All signals pass one Savitzky-Golay filter (``SMOOTH``), under which the identity still
holds. The gyro's white noise, differentiated into ``r'``, would dilute ``J`` (and, since
a steering delay is nearly ``l² r'/v_x`` times itself, move the delay: 40-50 ms on the
random family at a 0.15 s filter); the regression is corrected for the measured noise of
the gyro and the accelerometer (:func:`~roadgrip.inference.least_squares.eiv_lstsq`).

**Rear axle with a pose.** Where the drive has a pose (its delay fitted), its lateral
velocity ``v_y`` (:func:`~roadgrip.inference.fit_signals.pose_velocity`) measures the rear
slip angle, and ``alpha_r = F_yr/C_r + c``, ``F_yr = (m l_f a_y - I_z r')/l``, measures
``1/C_r`` directly (the constant ``c`` takes the pose's heading bias, ``v_x`` times which
it adds to ``v_y``). The pose's noise is on the dependent side, so it does not dilute. This
is a second, independent measurement of ``(l_r J/I_z - K)/l``, combined with the identity's
coefficients by generalised least squares
(:func:`~roadgrip.inference.least_squares.fuse_scalar`). The front axle's analogue is not
used: with the steering on its right-hand side it separates ``C_f`` from the steering scale
no better than the identity does.

Standard errors are least-squares errors inflated for the residuals' correlation
(``n_eff = n (1 - rho_1)/(1 + rho_1)``), propagated by the delta method; the coefficients'
include the delay's own error through their slope along the delay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.inference.channel_delays import MAX_SIDESLIP_LAG, ROLL_LAG, sideslip_lag
from roadgrip.inference.channel_delays import fit_delays as _delays
from roadgrip.inference.fit_signals import POSE_WINDOW
from roadgrip.inference.fit_signals import dilate as _dilate
from roadgrip.inference.fit_signals import half_width as _half_width
from roadgrip.inference.fit_signals import pose_velocity as _pose_velocity
from roadgrip.inference.fit_signals import shifted as _shifted
from roadgrip.inference.fit_signals import smooth as _smooth
from roadgrip.inference.fit_signals import uniform_dt as _uniform_dt
from roadgrip.inference.fitted_value import FittedValue
from roadgrip.inference.fitted_value import describe as _describe
from roadgrip.inference.fitted_value import fitted as _fitted
from roadgrip.inference.fitted_value import undetermined as _undetermined
from roadgrip.inference.gyro_fit import fit_gyro
from roadgrip.inference.least_squares import (
    eiv_lstsq,
    filter_noise_energy,
    fuse_scalar,
    held_samples,
    lstsq,
    n_eff,
)
from roadgrip.io.calibration import CALIBRATION, apply_calibration, corrected_yaw_rate
from roadgrip.io.derived import white_noise_std
from roadgrip.signals import WHEELS, undriven_wheels, wheel_speed_vx
from roadgrip.vehicle.params import CALIBRATION_KEY, FIELD_RANGES, VehicleParams

__all__ = ["MAX_SIDESLIP_LAG", "FittedValue", "VehicleFit", "fit_vehicle", "rear_axle_from_pose", "sideslip_lag"]

V_MIN = 5.0
"""Smallest speed [m/s] of a sample in the single-track fit (``r/v_x`` and the slip
angles are ill-conditioned below)."""
LINEAR_AY = 0.4
"""Linear range: ``|a_y| < LINEAR_AY mu g``."""
MAX_AX = 0.2 * GRAVITY
"""Largest ``|a_x|`` [m/s²] of a sample in the single-track fit (combined slip)."""
MIN_LINEAR = 500
"""Fewest linear-range samples for the single-track fit."""
MIN_AY_STD = 0.5
"""Least standard deviation [m/s²] of ``a_y`` over the linear-range samples (excitation)."""
ONE_SPEED_RATIO = 1.3
"""Turning counts as at one speed when the 90th percentile of the speed of the linear-range
samples with ``|a_y| >= MIN_AY_STD`` is below this times their 10th: the steering's scale
(``l r/v_x``) then trades against the understeer (``a_y = v_x r``), and the scale's and the
front stiffness's notes say so (on the
random family's ``dry-gravel-dry``, all turning at 11-12 m/s: median standard errors of the
scale 2.8 %, of the front stiffness 10.1 %; turning at 8-20 m/s on ``vehicle-id``: 0.18 % and
2.0 %)."""
MAX_REL_STD = 0.25
"""Largest relative standard error of a fitted gain, radius or stiffness (2 sigma: within
+-50 %); the value and its error are reported either way."""
MAX_STEER_LAG = 0.3
"""Largest steering delay [s] searched."""




@dataclass(frozen=True)
class VehicleFit:
    """Result of :func:`fit_vehicle`.

    Attributes
    ----------
    values : dict of str to FittedValue
        Every quantity, fitted or undetermined, in a fixed order.
    vehicle : VehicleParams
        The base vehicle with the fitted vehicle fields (cornering stiffnesses, wheel
        radius, roll gradient) replaced.
    samples : int
        Linear-range samples of the single-track fit.
    """

    values: dict[str, FittedValue]
    vehicle: VehicleParams
    samples: int = 0
    notes: tuple[str, ...] = field(default=())

    @property
    def calibration(self) -> dict[str, float]:
        """The fitted sensor calibration the vehicle file carries (``calibration:``)."""
        return {k: v.value for k, v in self.values.items() if k in CALIBRATION and v.fitted}

    def read(self, drive: Drive) -> Drive:
        """``drive`` as ``--vehicle`` of this fit's file reads it: its sensors calibrated
        (:func:`~roadgrip.io.calibration.apply_calibration`) and the fitted vehicle, under the
        drive's vehicle name."""
        out = apply_calibration(drive, self.calibration)
        return Drive(out.data, replace(out.meta, vehicle=self.vehicle.replace(name=drive.vehicle.name)))

    def to_yaml(self) -> str:
        """The vehicle file: every vehicle field, then each identified value as a comment
        with its standard error and status (sensor calibrations are not vehicle fields)."""
        import yaml

        lines = ["# roadgrip vehicle file written by `roadgrip vehicle fit`.",
                 "# Fitted fields carry their standard error; an undetermined one keeps the "
                 "base value."]
        body = yaml.safe_dump(self.vehicle.to_dict(), sort_keys=False).splitlines()
        for line in body:
            key = line.split(":", 1)[0]
            v = self.values.get(key)
            lines.append(line + (f"  # {_describe(v)}" if v is not None else ""))
        lines.append("# Sensor calibration, applied to every drive read with this file:")
        lines.append(f"{CALIBRATION_KEY}:")
        calibration = self.calibration
        fitted = [v for v in self.values.values() if v.name in calibration]
        for v in fitted:
            lines.append(f"  {v.name}: {v.value!r}  # {_describe(v)}")
        if not fitted:
            lines[-1] += " {}"
        for v in self.values.values():
            if v.name not in FIELD_RANGES and not (v.name in CALIBRATION and v.fitted):
                lines.append(f"# {v.name}: {_describe(v, value=True)}")
        return "\n".join(lines) + "\n"


def _accelerometer(drive: Drive, vx: NDArray, dt: float, acc_delay: float) -> dict[str, FittedValue]:
    """Gains and biases of ``a_y`` and ``a_x`` against the kinematics."""
    out: dict[str, FittedValue] = {}
    t = drive.t
    # a_y against v_x r alone: the pose's dv_y/dt, twice differentiated, is noisier than
    # the term itself (0.39 against 0.14 m/s² rms on a multi-body car) and in the regressor
    # diluted the gain to 0.98 where the body-mounted accelerometer reads 1.15 a_y; dv_y/dt
    # left out costs 0.01 there (1.14)
    kin_y = _smooth(vx * drive.col("yaw_rate"), dt, 0.5)
    ay = _smooth(_shifted(t, drive.col("ay"), acc_delay), dt, 0.5)
    sel = vx > 2.0
    for axis, meas, kin in (("y", ay, kin_y),):
        if sel.sum() < 200 or np.std(kin[sel]) < MIN_AY_STD:
            out[f"a{axis}_gain"] = _undetermined(f"a{axis}_gain", "-", "too little turning")
            out[f"a{axis}_bias"] = _undetermined(f"a{axis}_bias", "m/s²", "too little turning")
            continue
        X = np.column_stack([kin[sel], np.ones(sel.sum())])
        beta, cov, _ = lstsq(X, meas[sel])
        out[f"a{axis}_gain"] = _fitted(f"a{axis}_gain", beta[0], math.sqrt(cov[0, 0]), "-",
                                       "scale and roll (1 + g roll_gradient) together")
        out[f"a{axis}_bias"] = _fitted(f"a{axis}_bias", beta[1], math.sqrt(cov[1, 1]), "m/s²")
    if drive.has("ax"):
        ax = _smooth(_shifted(t, drive.col("ax"), acc_delay), dt, 0.5)
        dvx = _smooth(vx, dt, 0.5, deriv=1)
        sel = vx > 2.0
        if sel.sum() < 200 or np.std(dvx[sel]) < MIN_AY_STD:
            for k, u in (("ax_gain", "-"), ("ax_bias", "m/s²")):
                out[k] = _undetermined(k, u, "too little acceleration and braking")
        else:
            X = np.column_stack([dvx[sel], np.ones(sel.sum())])
            beta, cov, _ = lstsq(X, ax[sel])
            out["ax_gain"] = _fitted("ax_gain", beta[0], math.sqrt(cov[0, 0]), "-",
                                     "scale and pitch together")
            out["ax_bias"] = _fitted("ax_bias", beta[1], math.sqrt(cov[1, 1]), "m/s²",
                                     "with the mean road grade")
    return out


def _wheel_radius(drive: Drive, base: VehicleParams, dt: float) -> FittedValue:
    """Effective rolling radius from the undriven wheels against an independent speed."""
    free = undriven_wheels(base.drive)
    if not free.any():
        free = np.ones(4, bool)
    cols = [f"omega_{w}" for w, f in zip(WHEELS, free, strict=True) if f]
    if not drive.has(*cols):
        return _undetermined("wheel_radius", "m", "no wheel speeds", base.wheel_radius)
    if drive.has_pose:
        vx = _pose_velocity(drive)[0]
        src = "the pose"
    elif drive.has("vx"):
        vx, src = drive.col("vx"), "the vx column"
    else:
        return _undetermined("wheel_radius", "m", "no pose and no vx column to compare with",
                             base.wheel_radius)
    omega = np.mean([drive.col(c) for c in cols], axis=0)
    steer = np.abs(drive.col("steer")) if drive.has("steer") else np.zeros(drive.n)
    front = all(c.startswith("omega_f") for c in cols)
    if front:  # a front wheel rolls along the steered direction
        omega = omega * np.cos(steer)
    sel = np.isfinite(vx) & (vx > 3.0) & (omega > 0)
    if drive.has("ax"):
        sel &= np.abs(drive.col("ax")) < 1.0
    if sel.sum() < 200:
        return _undetermined("wheel_radius", "m", f"fewer than 200 samples above 3 m/s with {src}",
                             base.wheel_radius)
    X = omega[sel, None]
    beta, cov, _ = lstsq(X, vx[sel])
    R, sd = float(beta[0]), math.sqrt(float(cov[0, 0]))
    lo, hi = FIELD_RANGES["wheel_radius"][:2]
    if not (lo <= R <= hi) or sd > MAX_REL_STD * R:
        return _undetermined("wheel_radius", "m", f"{src}: radius {R:.3g} ± {sd:.2g} m",
                             base.wheel_radius)
    return _fitted("wheel_radius", R, sd, "m", f"{', '.join(cols)} against {src}")


def _regressor_noise(drive: Drive, L: float, m: float, vx: NDArray, dt: float,
                     acc_delay: float) -> NDArray:
    """Summed noise covariance ``E[dX' dX]``, shape (4, 4), of the single-track regressors
    ``[l r/v_x, 1, m a_y/l, r'/l]`` over the selected samples (``vx`` [m/s], shape (n,);
    ``m`` [kg] the factor of the raw ``a_y`` column):
    the gyro's and the accelerometer's white noise (:func:`white_noise_std` of the raw
    columns) through the filters of :func:`_smooth`. A smoothed and a differentiated copy
    of one noise are uncorrelated (a symmetric against an antisymmetric kernel)."""
    s_r = white_noise_std(drive.col("yaw_rate"))
    s_a = white_noise_std(drive.col("ay"))
    s_r = s_r if math.isfinite(s_r) else 0.0
    s_a = s_a if math.isfinite(s_a) else 0.0
    out = np.zeros((4, 4))
    h = _half_width(dt)
    out[0, 0] = s_r**2 * filter_noise_energy(h) * float(np.sum((L / vx) ** 2))
    out[2, 2] = len(vx) * (m / L * s_a) ** 2 * filter_noise_energy(h, shift=acc_delay / dt)
    out[3, 3] = len(vx) * (s_r / L) ** 2 * filter_noise_energy(h, 1, dt)
    return out


def _near_holds(drive: Drive, dt: float, acc_delay: float, lag: int) -> NDArray:
    """Samples whose single-track regressors or steering (at any lag up to ``lag``
    samples) see a value held by the logger (:func:`held_samples`): a hold is the channel
    late by up to its length, which the delay profile would take for latency."""
    h = _half_width(dt)
    bad = _dilate(held_samples(drive.col("yaw_rate")), h + 1)
    bad |= _dilate(held_samples(drive.col("steer")), h + lag + 1)
    ay_held = _dilate(held_samples(drive.col("ay")), h + 1)
    return bad | (_shifted(drive.t, ay_held.astype(float), acc_delay) > 0)


def rear_axle_from_pose(drive: Drive, base: VehicleParams, vx: NDArray, dt: float, acc_delay: float,
                        pose_delay: float, mu: float) -> tuple[float, float, int] | None:
    """``1/C_r`` [rad/N] from the pose's lateral velocity (module docstring, "Rear axle with
    a pose").

    Parameters
    ----------
    drive : Drive
        With ``x``, ``y``, ``psi``, ``yaw_rate``, ``ay`` (``ax`` if present).
    base : VehicleParams
        Mass, axle distances, yaw inertia and roll gradient.
    vx : ndarray, shape (n,)
        Longitudinal speed [m/s].
    dt : float
        Sample spacing [s].
    acc_delay, pose_delay : float
        The accelerometer's and the pose's delay behind the gyro [s].
    mu : float
        Friction of the road driven [-] (linear range ``|a_y| < LINEAR_AY mu g``).

    Returns
    -------
    (inv_cr, var, n, heading_bias, heading_var) or None
        ``1/C_r`` [rad/N], its variance (least squares, inflated for correlated residuals),
        the samples used, and the constant [rad] with its variance: the pose's heading bias
        (a heading ``b`` too large puts ``-v_x b`` into the pose's ``v_y``, ``+b`` into the
        rear slip angle); None without a pose, with fewer than :data:`MIN_LINEAR`
        linear-range samples or a non-positive slope.
    """
    if not drive.has_pose:
        return None
    t = drive.t
    L, m, Iz = base.wheelbase, base.mass, base.yaw_inertia
    vy = _pose_velocity(drive)[1]
    known = _shifted(t, np.isfinite(vy).astype(float), pose_delay) > 0.999
    vy = _shifted(t, np.where(np.isfinite(vy), vy, 0.0), pose_delay)
    roll = 1.0 + GRAVITY * base.roll_gradient
    ay = _smooth(_shifted(t, drive.col("ay"), acc_delay), dt, POSE_WINDOW) / roll
    ax = (_smooth(_shifted(t, drive.col("ax"), acc_delay), dt, POSE_WINDOW) if drive.has("ax")
          else np.zeros(drive.n))
    r = _smooth(drive.col("yaw_rate"), dt, POSE_WINDOW)
    rdot = _smooth(drive.col("yaw_rate"), dt, POSE_WINDOW, deriv=1)
    vxs = _smooth(vx, dt, POSE_WINDOW)
    edge = _half_width(dt, POSE_WINDOW) + round(abs(pose_delay) / dt) + 1
    sel = known & (vxs >= V_MIN) & (np.abs(ay) < LINEAR_AY * mu * GRAVITY) & (np.abs(ax) < MAX_AX)
    sel[:edge] = sel[-edge:] = False
    sel &= ~_near_holds(drive, dt, acc_delay, 0)
    n = int(sel.sum())
    if n < MIN_LINEAR:
        return None
    force = (m * base.lf * ay[sel] - Iz * rdot[sel]) / L
    alpha = -(vy[sel] - base.lr * r[sel]) / vxs[sel]
    beta, cov, _ = lstsq(np.column_stack([force, np.ones(n)]), alpha)
    if not beta[0] > 0:
        return None
    return float(beta[0]), float(cov[0, 0]), n, float(beta[1]), float(cov[1, 1])


def _single_track(drive: Drive, base: VehicleParams, vx: NDArray, dt: float, acc_delay: float,
                  mu: float, pose_delay: float | None = None) -> tuple[dict[str, FittedValue], int]:
    """Steering delay, scale, offset and both cornering stiffnesses (module docstring)."""
    t = drive.t
    L, m = base.wheelbase, base.mass
    r = _smooth(drive.col("yaw_rate"), dt)
    rdot = _smooth(drive.col("yaw_rate"), dt, deriv=1)
    roll = 1.0 + GRAVITY * base.roll_gradient  # a_y's reading over the CG's acceleration
    ay = _smooth(_shifted(t, drive.col("ay"), acc_delay), dt) / roll
    ax = _smooth(_shifted(t, drive.col("ax"), acc_delay), dt) if drive.has("ax") else np.zeros(drive.n)
    steer = _smooth(drive.col("steer"), dt)
    vxs = _smooth(vx, dt)
    edge = round(MAX_STEER_LAG / dt) + 1
    sel = (vxs >= V_MIN) & (np.abs(ay) < LINEAR_AY * mu * GRAVITY) & (np.abs(ax) < MAX_AX)
    sel[:edge] = sel[-edge:] = False
    sel &= ~_near_holds(drive, dt, acc_delay, edge)
    n = int(sel.sum())
    names = {"steer_delay": "s", "steer_scale": "-", "steer_offset": "rad",
             "understeer_K": "rad/N", "cornering_stiffness_front": "N/rad",
             "cornering_stiffness_rear": "N/rad"}
    ay_std = float(np.std(ay[sel])) if n else 0.0
    if n < MIN_LINEAR or ay_std < MIN_AY_STD:
        why = (f"{n} linear-range samples above {V_MIN:g} m/s, a_y std {ay_std:.2f} m/s² "
               f"(needs {MIN_LINEAR} and {MIN_AY_STD:g})")
        out = {k: _undetermined(k, u, why, getattr(base, k, math.nan)) for k, u in names.items()}
        out["pose_heading_bias"] = _undetermined("pose_heading_bias", "rad", why)
        return out, n
    X = np.column_stack([L * r[sel] / vxs[sel], np.ones(n), m * ay[sel] / L, rdot[sel] / L])
    noise = _regressor_noise(drive, L, m / roll, vxs[sel], dt, acc_delay)
    lags = np.arange(-edge + 1, edge)
    rss = np.array([eiv_lstsq(X, np.roll(steer, -k)[sel], noise)[3] for k in lags])
    i = int(np.argmin(rss))
    lag = float(lags[i])
    if 0 < i < len(rss) - 1:
        y0, y1, y2 = rss[i - 1], rss[i], rss[i + 1]
        den = y0 - 2 * y1 + y2
        lag += 0.5 * (y0 - y2) / den if den > 0 else 0.0
    d = lag * dt
    y = _shifted(t, steer, d)[sel]
    beta, cov, rss_min, _ = eiv_lstsq(X, y, noise)
    # delay standard error: the profile's curvature (RSS rises by RSS/n_eff per sigma²)
    n_res = n_eff(y - X @ beta)
    curv = (rss[min(i + 1, len(rss) - 1)] - 2 * rss[i] + rss[max(i - 1, 0)]) / dt**2
    d_std = math.sqrt(2.0 * rss_min / n_res / curv) if curv > 0 else math.nan
    if math.isfinite(d_std):  # the delay trades off against J (a shift is ~ l² r'/v_x)
        slope = (eiv_lstsq(X, _shifted(t, steer, d + dt)[sel], noise)[0] - beta) / dt
        cov = cov + np.outer(slope, slope) * d_std**2
    pose_rear = (rear_axle_from_pose(drive, base, vx, dt, acc_delay, pose_delay, mu)
                 if pose_delay is not None else None)
    if pose_rear is not None:  # 1/C_r = (l_r J/I_z - K)/l, measured again by the pose
        beta, cov = fuse_scalar(beta, cov, lambda b: (base.lr * b[3] / base.yaw_inertia - b[2])
                                / b[0] / L, pose_rear[0], pose_rear[1])
        heading = _fitted("pose_heading_bias", pose_rear[3], math.sqrt(pose_rear[4]), "rad",
                          "the constant of the rear axle's slip against the pose's v_y")
    else:
        heading = _undetermined("pose_heading_bias", "rad", "needs a pose with its delay fitted "
                                "and linear-range turning")
    s = 1.0 / beta[0]

    def params(b):
        s_ = 1.0 / b[0]
        K, J = b[2] * s_, b[3] * s_
        u = (K + base.lf * J / base.yaw_inertia) / L
        w = (base.lr * J / base.yaw_inertia - K) / L
        return np.array([s_, -b[1] * s_, K, 1.0 / u, 1.0 / w])

    p = params(beta)
    jac = np.empty((5, 4))
    for k in range(4):
        h = 1e-6 * max(abs(beta[k]), 1e-12)
        bp = beta.copy()
        bp[k] += h
        jac[:, k] = (params(bp) - p) / h
    var = np.diag(jac @ cov @ jac.T)
    pstd = np.sqrt(np.maximum(var, 0.0))
    out: dict[str, FittedValue] = {"pose_heading_bias": heading}
    at_edge = i in (0, len(rss) - 1)
    if at_edge or not math.isfinite(d_std):
        out["steer_delay"] = _undetermined("steer_delay", "s", "no residual minimum within "
                                           f"±{MAX_STEER_LAG:g} s")
    else:
        out["steer_delay"] = _fitted("steer_delay", d, d_std, "s", "steering behind the gyro")
    turning = sel & (np.abs(ay) >= MIN_AY_STD)  # the samples that weigh in the scale and K
    v10, v90 = np.percentile(vxs[turning if turning.sum() >= 100 else sel], [10, 90])
    one_speed = (f"; turning at one speed ({v10:.0f}-{v90:.0f} m/s): the scale trades against the "
                 "understeer, turning at several speeds pins both" if v90 < ONE_SPEED_RATIO * v10 else "")
    out["steer_scale"] = _fitted("steer_scale", s, pstd[0], "-", "road-wheel angle per steer unit" + one_speed)
    out["steer_offset"] = _fitted("steer_offset", p[1], pstd[1], "rad",
                                  "road-wheel angle at steer 0 (with the sensor biases)")
    out["understeer_K"] = _fitted("understeer_K", p[2], pstd[2], "rad/N", "l_r/C_f - l_f/C_r")
    for k, name in ((3, "cornering_stiffness_front"), (4, "cornering_stiffness_rear")):
        lo, hi = FIELD_RANGES[name][:2]
        if not (lo <= p[k] <= hi) or pstd[k] > MAX_REL_STD * p[k]:
            out[name] = _undetermined(name, "N/rad", f"fit {p[k]:.4g} ± {pstd[k]:.2g} N/rad "
                                      "(too little transient yaw excitation)", getattr(base, name))
        else:
            out[name] = _fitted(name, p[k], pstd[k], "N/rad",
                                f"with yaw_inertia {base.yaw_inertia:g} kg m²"
                                + (f"; rear axle also from the pose ({pose_rear[2]} samples)"
                                   if pose_rear is not None else "")
                                + (one_speed if k == 3 else ""))
    front, rear = out["cornering_stiffness_front"], out["cornering_stiffness_rear"]
    if front.fitted != rear.fitted:  # one axle alone would change the balance (K): keep both
        for k, name in ((3, "cornering_stiffness_front"), (4, "cornering_stiffness_rear")):
            out[name] = _undetermined(name, "N/rad", f"fit {p[k]:.4g} ± {pstd[k]:.2g} N/rad; the "
                                      "other axle is undetermined, both kept", getattr(base, name))
    if abs(s - 1.0) > 0.5 or pstd[0] > MAX_REL_STD * abs(s):
        for k in ("steer_scale", "steer_offset"):
            out[k] = _undetermined(k, names[k], f"scale {s:.3g} ± {pstd[0]:.2g}: steering does "
                                   "not explain the yaw rate")
    return out, n


def fit_vehicle(drive: Drive, base: VehicleParams | None = None, *, mu: float = 1.0,
                roll_lag: float = ROLL_LAG) -> VehicleFit:
    """Identify the vehicle and sensor parameters of a drive (module docstring).

    Parameters
    ----------
    drive : Drive
        Needs ``yaw_rate``, ``ay``, ``steer`` and a speed (:func:`~roadgrip.signals.wheel_speed_vx`);
        uses ``ax``, the wheel speeds and the pose where present.
    base : VehicleParams, optional
        Mass, axle distances, yaw inertia and the values kept where the drive cannot tell;
        default the drive's vehicle.
    mu : float
        Friction of the road driven [-], for the linear range ``|a_y| < 0.4 mu g``.
    roll_lag : float
        The body's roll behind the lateral acceleration [s], taken off the accelerometer's
        delay in proportion to the roll's share of its reading
        (:func:`~roadgrip.inference.channel_delays.fit_delays`); default
        :data:`~roadgrip.inference.channel_delays.ROLL_LAG`.

    Returns
    -------
    VehicleFit

    Raises
    ------
    DriveValidationError
        A required column is missing (named).
    ValueError
        ``mu`` outside (0, 2], ``roll_lag`` outside [0, 0.5] s, or a drive with fewer than
        100 samples.
    """
    if not (0.0 < mu <= 2.0):
        raise ValueError(f"mu must be in (0, 2], got {mu!r}")
    if not (0.0 <= roll_lag <= 0.5):
        raise ValueError(f"roll_lag must be in [0, 0.5] s, got {roll_lag!r}")
    base = drive.vehicle if base is None else base
    drive.require("yaw_rate", "ay", "steer", why="vehicle fit")
    if drive.n < 100:
        raise ValueError(f"drive from {drive.meta.source} has {drive.n} samples; a vehicle fit "
                         "needs at least 100")
    t = drive.t
    dt = _uniform_dt(t)
    if np.max(np.diff(t)) > 3.0 * dt:
        # the filters and lags assume a uniform clock: resample gaps away
        grid = t[0] + dt * np.arange(int((t[-1] - t[0]) / dt) + 1)
        df = drive.data[[c for c in drive.data.columns if drive.data[c].dtype.kind in "fiu"]]
        df = df.apply(lambda c: np.interp(grid, t, c.to_numpy(float)))
        df["t"] = grid
        drive = Drive(df.reset_index(drop=True), drive.meta)
        t = grid
    vx, src = wheel_speed_vx(drive)
    values = _delays(drive, vx, src, dt, base, roll_lag)
    values.update(fit_gyro(drive, dt, values.get("delay_pose")))
    if values["yaw_rate_scale"].fitted:  # the rest of the fit reads the corrected gyro
        df = drive.data.copy()
        df["yaw_rate"] = corrected_yaw_rate(drive.col("yaw_rate"), {
            k: values[k].value for k in ("yaw_rate_bias", "yaw_rate_scale")})
        drive = Drive(df, drive.meta)
    acc = values["delay_accelerometer"]
    acc_delay = acc.value if acc.fitted else 0.0
    pose = values.get("delay_pose")
    st, n_lin = _single_track(drive, base, vx, dt, acc_delay, mu,
                              pose.value if pose is not None and pose.fitted else None)
    values.update(st)
    values.update(_accelerometer(drive, vx, dt, acc_delay))
    values["wheel_radius"] = _wheel_radius(drive, base, dt)
    values["yaw_inertia"] = _undetermined("yaw_inertia", "kg m²",
                                          "kept from the base vehicle (needs v_y: only J = "
                                          "I_z (1/C_f + 1/C_r) is observed)", base.yaw_inertia)
    gain = values.get("ay_gain")
    if gain is not None and gain.fitted and gain.value - 1.0 > 2.0 * gain.std:
        rg = (gain.value - 1.0) / GRAVITY
        values["roll_gradient"] = _fitted("roll_gradient", rg, gain.std / GRAVITY, "rad/(m/s²)",
                                          "from a_y's gain, if the accelerometer's scale is 1")
    else:
        values["roll_gradient"] = _undetermined("roll_gradient", "rad/(m/s²)",
                                                "a_y's gain is 1 within 2 standard errors",
                                                base.roll_gradient)
    changes = {k: v.value for k, v in values.items()
               if v.fitted and k in FIELD_RANGES and k != "yaw_inertia"}
    try:
        vehicle = base.replace(**changes)
    except ValueError as exc:  # a combination the vehicle checks refuse: keep the base
        vehicle = base
        values = {k: (_undetermined(k, v.unit, f"refused with the base vehicle: {exc}",
                                    getattr(base, k)) if k in changes else v)
                  for k, v in values.items()}
    return VehicleFit(values, vehicle, n_lin)
