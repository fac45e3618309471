"""Each channel's delay against the gyro, for ``roadgrip vehicle fit``: the accelerometer's
two axes, the speed and the pose (:func:`fit_delays`), and the lag the sideslip rate lends
``a_y`` where no pose measures it (:func:`sideslip_lag`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.inference.fit_signals import dilate as _dilate
from roadgrip.inference.fit_signals import fill_held, pose_velocity, usable
from roadgrip.inference.fit_signals import smooth as _smooth
from roadgrip.inference.fitted_value import FittedValue
from roadgrip.inference.fitted_value import fitted as _fitted
from roadgrip.inference.fitted_value import undetermined as _undetermined
from roadgrip.sensor_delay import estimate_delay
from roadgrip.vehicle.params import VehicleParams

__all__ = ["BRAKING", "MAX_SIDESLIP_LAG", "ROLL_LAG", "ROLL_LAG_STD", "fit_delays", "roll_share", "sideslip_lag"]

BRAKING = 0.5
"""Deceleration [m/s²] above which the wheels are taken as braked (slipping)."""
MAX_SIDESLIP_LAG = 0.02
"""Largest delay [s] the unmeasured sideslip rate may lend ``a_y`` (:func:`sideslip_lag`)
for its delay against the gyro to be fitted without a pose: the family's tolerance. The
full-size race car at 40 m/s: 113 ms found, where its INS's own lateral velocity puts
``a_y`` 25 ms behind the gyro."""

ROLL_LAG = 0.045
"""Default lag [s] of the body's roll behind the lateral acceleration (the roll mode's
damping over its stiffness, at the low frequencies of driving): 49-50 ms on the multi-body
Ford Escort, 42-43 ms on the VW Vanagon (their true roll against their true ``a_y``; 38-58 ms
over the random family)."""
ROLL_LAG_STD = 0.015
"""Its uncertainty [s], added to the accelerometer delay's standard error times the roll's
share of the reading (:func:`roll_share`)."""


def roll_share(base: VehicleParams) -> float:
    """The share of a body-mounted accelerometer's ``a_y`` reading that is the body's roll,
    ``g k/(1 + g k)`` with ``k`` the roll gradient [rad/(m/s²)]: the sensor tilts with the body
    and reads ``g`` times the roll angle besides the acceleration."""
    k = GRAVITY * base.roll_gradient
    return k / (1.0 + k)


def _ax_dvx(drive: Drive, vy: NDArray | None) -> NDArray:
    """``dv_x/dt`` [m/s²] from the accelerometer: ``a_x + v_y r``, ``v_y`` from the pose where
    it has one (in a turn ``v_y r`` is not small: left out, it moves a delay fitted on
    ``a_x`` alone by 10-20 ms), else ``a_x``."""
    if vy is None:
        return drive.col("ax")
    return drive.col("ax") + np.where(np.isfinite(vy), vy, 0.0) * drive.col("yaw_rate")


def _ax_delay(drive: Drive, pose: FittedValue | None, acc: FittedValue, v_pose: NDArray | None,
              dvx: NDArray) -> FittedValue | None:
    """Delay of ``a_x`` against the gyro (``delay_accelerometer_x``): the integral of ``a_x +
    v_y r`` (``dv_x/dt``; ``v_y`` from the pose) against the pose's speed (a delay commutes
    with the integral; the pose differentiated would be noisier), plus the pose's own delay
    behind the gyro. ``a_x`` and ``a_y`` may be
    separate messages with their own latencies, so ``a_y``'s delay does not time ``a_x``.
    Undetermined without ``x, y, psi``, with the pose's delay undetermined or too little
    change of speed; its value is then ``a_y``'s (``acc``), which the calibration applies to
    ``a_x`` in its place. ``v_pose``: the pose's speed [m/s]; ``dvx``: :func:`_ax_dvx`.
    None without ``a_x``."""
    if not drive.has("ax"):
        return None
    why = None
    if not drive.has_pose:
        why = "no pose"
    elif pose is None or not pose.fitted:
        why = "the pose's delay is undetermined"
    else:
        t = drive.t
        ok = np.isfinite(v_pose)
        if ok.mean() <= 0.5:
            why = "the pose's speed is known on half the drive or less"
        else:
            v_ax = np.concatenate(([0.0], np.cumsum(0.5 * (dvx[1:] + dvx[:-1]) * np.diff(t))))
            fit = estimate_delay(t, v_ax, v_pose, valid=ok, max_lag=1.0)
            if fit.reliable:
                return _fitted("delay_accelerometer_x", fit.delay + pose.value,
                               math.hypot(fit.std, pose.std), "s",
                               f"integral of a_x ~ the pose's speed (peak correlation "
                               f"{fit.peak_corr:.2f}) plus the pose's delay")
            why = (f"integral of a_x ~ the pose's speed: peak correlation {fit.peak_corr:.2f} "
                   "(too little change of speed)")
    kept = acc.value if acc.fitted else math.nan
    return _undetermined("delay_accelerometer_x", "s",
                         f"{why}; a_x is moved by delay_accelerometer (a_y's)", kept)


def _speed_delay(drive: Drive, vx: NDArray, src: str, dt: float, ax_delay: FittedValue | None,
                 acc: FittedValue, dvx: NDArray) -> FittedValue | None:
    """Delay of the speed (:func:`wheel_speed_vx`) against the gyro: ``dv_x/dt`` against
    ``a_x``, plus ``a_x``'s delay (``ax_delay``, :func:`_ax_delay`; where undetermined,
    ``a_y``'s, ``acc``). Wheel speeds (``src``) are used outside braking (``a_x < -BRAKING``,
    widened by 1 s): a braked wheel slips, and its speed falls ahead of the car's. None
    without ``a_x``. ``dvx``: :func:`_ax_dvx`."""
    if not drive.has("ax") or ax_delay is None:
        return None
    t = drive.t
    rolling = np.ones(drive.n, bool)
    if src == "wheels":
        rolling = ~_dilate(drive.col("ax") < -BRAKING, round(1.0 / dt))
    fit = estimate_delay(t, _smooth(vx, dt, 0.5, deriv=1), dvx, signal_valid=rolling,
                         max_lag=1.0)
    if not fit.reliable:
        return _undetermined("delay_speed", "s", f"dv_x/dt ~ a_x: peak correlation {fit.peak_corr:.2f} "
                             "(too little acceleration and braking)")
    if ax_delay.fitted:
        ax_clock = (ax_delay.value, ax_delay.std, "a_x timed by the pose (delay_accelerometer_x)")
    elif acc.fitted:
        ax_clock = (acc.value, acc.std, "a_x on a_y's clock")
    else:
        return _undetermined("delay_speed", "s", "a_x's delay undetermined (no pose, a_y untimed)")
    return _fitted("delay_speed", fit.delay + ax_clock[0], math.hypot(fit.std, ax_clock[1]), "s",
                   f"dv_x/dt ~ a_x (peak correlation {fit.peak_corr:.2f}), {ax_clock[2]}")


def sideslip_lag(base: VehicleParams, vx: float) -> float:
    """The delay [s] that the sideslip rate lends ``a_y`` against ``v_x r``.

    In a turn of a linear single-track car the lateral velocity follows the lateral
    acceleration, ``v_y = l_r r - v_x alpha_r`` with ``alpha_r = m l_f a_y / (l C_r)``, so
    ``a_y = v_x r + dv_y/dt ~ v_x r + (l_r / v_x - c v_x) da_y/dt`` (``c = m l_f / (l C_r)``):
    against ``v_x r`` alone, ``a_y`` looks late by ``c v_x - l_r / v_x``. Measured against
    the simulator's truth (a sedan at 14 m/s, no pose): -13 ms found where this gives -12 ms.

    Parameters
    ----------
    base : VehicleParams
        Mass, axle distances and the rear cornering stiffness.
    vx : float
        The speed of the turns [m/s].
    """
    c = base.mass * base.lf / (base.wheelbase * base.cornering_stiffness_rear)
    return c * vx - base.lr / max(vx, 1e-3)


def fit_delays(drive: Drive, vx: NDArray, src: str, dt: float,
               base: VehicleParams, roll_lag: float = ROLL_LAG) -> dict[str, FittedValue]:
    """Delays of the accelerometer's two axes, the speed and the pose against the gyro.

    ``a_y``'s delay is its sensor's latency: a body-mounted accelerometer reads the roll
    angle too (:func:`roll_share` of the reading, from ``base.roll_gradient``), and the roll
    follows ``a_y`` ``roll_lag`` [s] late, so the reading as a whole looks later than the
    sensor by the share times the lag, which is taken off. On the random family (shares of
    0.10-0.17 from the files' roll gradients) the delay found on ``dry-gravel-dry`` was +1 to
    +13 ms behind the latency (mean +7.8), less the share times :data:`ROLL_LAG` -3 to +6
    ms (mean +2.1); on ``vehicle-id`` +0 to +14 (mean +8.8), now -4 to +9 (mean +3.1). The
    GP-SSM reads the calibrated ``a_y`` as the acceleration times a gain: with the latency
    its snow-slalom curves pass on 17 of the family's 20 cars, with the whole lag on 12."""
    out: dict[str, FittedValue] = {}
    t = drive.t
    r = drive.col("yaw_rate")
    ref = vx * r
    pose_v = pose_velocity(drive)  # once: every delay below that uses the pose reads it
    vy = usable(pose_v[1]) if pose_v is not None else None
    pair = "a_y ~ v_x r"
    if vy is not None:
        ok = np.isfinite(vy)
        ref = ref + np.where(ok, _smooth(np.where(ok, vy, 0.0), dt, 0.5, deriv=1), 0.0)
        pair = "a_y ~ v_x r + dv_y/dt"
    acc = estimate_delay(t, drive.col("ay"), ref, max_lag=1.0)
    turning = np.abs(drive.col("ay")) > 1.0
    v_turn = float(np.median(vx[turning])) if turning.any() else 0.0
    lag = sideslip_lag(base, v_turn) if vy is None and v_turn > 0 else 0.0
    if abs(lag) > MAX_SIDESLIP_LAG:
        out["delay_accelerometer"] = _undetermined(
            "delay_accelerometer", "s", f"{pair} without a pose: the sideslip rate at "
            f"{v_turn:.0f} m/s looks like {1e3 * lag:+.0f} ms (c v_x - l_r/v_x), beyond "
            f"{1e3 * MAX_SIDESLIP_LAG:.0f} ms; found {1e3 * acc.delay:.0f} ± {1e3 * acc.std:.0f} ms")
    elif acc.reliable:
        share = roll_share(base)
        out["delay_accelerometer"] = _fitted(
            "delay_accelerometer", acc.delay - share * roll_lag, math.hypot(acc.std, share * ROLL_LAG_STD), "s",
            f"{pair}, peak correlation {acc.peak_corr:.2f}, found {1e3 * acc.delay:.1f} ms, less the body "
            f"roll's share of the reading ({share:.3f}) times its lag behind a_y ({1e3 * roll_lag:.0f} ms)")
    else:
        out["delay_accelerometer"] = _undetermined(
            "delay_accelerometer", "s", f"{pair}: peak correlation {acc.peak_corr:.2f}, "
            f"standard error {acc.std:.3g} s (too little turning)")
    if drive.has("psi"):
        rate = np.gradient(fill_held(t, np.unwrap(drive.col("psi"))), t)
        fit = estimate_delay(t, rate, r, max_lag=1.0)
        if fit.reliable:
            out["delay_pose"] = _fitted("delay_pose", fit.delay, fit.std, "s",
                                        f"dpsi/dt ~ r, peak correlation {fit.peak_corr:.2f}")
        else:
            out["delay_pose"] = _undetermined("delay_pose", "s", "dpsi/dt ~ r: too little turning")
    dvx = _ax_dvx(drive, vy) if drive.has("ax") else np.zeros(drive.n)
    ax_delay = _ax_delay(drive, out.get("delay_pose"), out["delay_accelerometer"],
                         pose_v[0] if pose_v is not None else None, dvx)
    if ax_delay is not None:
        out["delay_accelerometer_x"] = ax_delay
    speed = _speed_delay(drive, vx, src, dt, ax_delay, out["delay_accelerometer"], dvx)
    if speed is not None:
        out["delay_speed"] = speed
    return out
